#include "hexsim/magnetics/compass_model.h"

#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <gtest/gtest.h>

#include "hexsim/common/rng.h"
#include "hexsim/common/rotation.h"

namespace hexsim::magnetics {
namespace {

// A plausible sensor: soft iron within ±5 % of identity, tens of µT hard iron, a 2° misalignment,
// a soft iron that changes by 1e-3 per ampere, and a 3 % scale error.
CompassErrorParams RandomParams(RngStream& rng) {
  CompassErrorParams p;
  p.soft_iron = Eigen::Matrix3d::Identity();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) p.soft_iron(i, j) += 0.05 * (2 * rng.Uniform() - 1);
  p.hard_iron_uT = rng.Normal3(20.0);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) p.soft_iron_per_A(i, j) = 1e-3 * (2 * rng.Uniform() - 1);
  p.R_SB = QuatExp(rng.Normal3(1.0).normalized() * 2.0 * kDegToRad).toRotationMatrix();
  p.scale = 1.03;
  return p;
}

TEST(CompassModel, GivenIdealSensor_WhenReading_ThenItIsTheTrueField) {
  const CompassErrorParams ideal;
  const Eigen::Vector3d H(21.0, -3.5, 48.0);
  EXPECT_EQ(ApplyCompassError(ideal, H, 53.0), H);
}

TEST(CompassModel, GivenOnlySoftAndHardIron_WhenReading_ThenItIsPaperEquation3) {
  CompassErrorParams p;
  p.soft_iron << 1.02, 0.01, -0.03, 0.01, 0.97, 0.02, -0.03, 0.02, 1.05;
  p.hard_iron_uT = {12.0, -7.0, 30.0};
  const Eigen::Vector3d H_true(21.0, -3.5, 48.0);
  const Eigen::Vector3d expected = p.soft_iron * H_true + p.hard_iron_uT;  // H = K·H̃ + β
  EXPECT_LT((ApplyCompassError(p, H_true, 0.0) - expected).norm(), 1e-12);
  EXPECT_LT((ApplyCompassError(p, H_true, 40.0) - expected).norm(), 1e-12);  // no dK/dI: current-free
}

TEST(CompassModel, GivenCurrentDependentSoftIron_WhenCurrentChanges_ThenReadingChangesByRotatedScaledIdKH) {
  RngStream rng(3, "compass_dkdi");
  const CompassErrorParams p = RandomParams(rng);
  const Eigen::Vector3d H_true(21.0, -3.5, 48.0);
  const double I_A = 32.0;
  const Eigen::Vector3d change = ApplyCompassError(p, H_true, I_A) - ApplyCompassError(p, H_true, 0.0);
  const Eigen::Vector3d expected = p.R_SB * (p.scale * I_A * p.soft_iron_per_A * H_true);
  EXPECT_LT((change - expected).norm(), 1e-12 * H_true.norm());
}

TEST(CompassModel, GivenTrueFieldsOnASphere_WhenRead_ThenReadingsLieOnTheEllipsoidOfPaperEq4) {
  // With A = R_SB·scale·K(I): (H − β)ᵀ(A Aᵀ)⁻¹(H − β) = |H̃|² for every attitude.
  RngStream rng(5, "compass_ellipsoid");
  const CompassErrorParams p = RandomParams(rng);
  const double I_A = 20.0;
  const Eigen::Matrix3d A = p.R_SB * p.scale * (p.soft_iron + I_A * p.soft_iron_per_A);
  const Eigen::Matrix3d Q = (A * A.transpose()).inverse();
  const double radius_uT = 54.5;
  for (int k = 0; k < 100; ++k) {
    const Eigen::Vector3d H_true = radius_uT * rng.Normal3(1.0).normalized();
    const Eigen::Vector3d d = ApplyCompassError(p, H_true, I_A) - p.hard_iron_uT;
    EXPECT_NEAR(d.dot(Q * d), radius_uT * radius_uT, 1e-9 * radius_uT * radius_uT);
  }
}

TEST(CompassModel, GivenPureMisalignment_WhenReading_ThenTheMagnitudeIsUnchanged) {
  RngStream rng(9, "compass_misalign");
  CompassErrorParams p;
  p.R_SB = QuatExp(Eigen::Vector3d(0.02, -0.03, 0.05)).toRotationMatrix();
  for (int k = 0; k < 20; ++k) {
    const Eigen::Vector3d H_true = rng.Normal3(30.0);
    EXPECT_NEAR(ApplyCompassError(p, H_true, 10.0).norm(), H_true.norm(), 1e-12 * H_true.norm());
  }
}

TEST(CompassModel, GivenAnyWellConditionedModel_WhenInverted_ThenTheTrueFieldIsRecovered) {
  RngStream rng(21, "compass_invert");
  for (int trial = 0; trial < 20; ++trial) {
    const CompassErrorParams p = RandomParams(rng);
    const Eigen::Vector3d H_true = rng.Normal3(30.0);
    const double I_A = 60.0 * rng.Uniform();
    Eigen::Vector3d recovered;
    ASSERT_TRUE(InvertCompassError(p, ApplyCompassError(p, H_true, I_A), I_A, &recovered));
    EXPECT_LT((recovered - H_true).norm(), 1e-10 * H_true.norm());
  }
}

TEST(CompassModel, GivenASingularSoftIron_WhenInverted_ThenItRefusesAndLeavesTheOutputAlone) {
  CompassErrorParams p;
  p.soft_iron = Eigen::Matrix3d::Zero();
  p.soft_iron(0, 0) = 1.0;
  p.soft_iron(1, 1) = 1.0;
  Eigen::Vector3d out(1.0, 2.0, 3.0);
  EXPECT_FALSE(InvertCompassError(p, Eigen::Vector3d(10, 20, 30), 0.0, &out));
  EXPECT_EQ(out, Eigen::Vector3d(1.0, 2.0, 3.0));
}

TEST(CompassModel, GivenAVehicleWithWiring_WhenTheFullReadingIsFormed_ThenItIsEarthInBodyPlusWiringThroughTheErrorModel) {
  RngStream rng(41, "compass_full");
  const CompassErrorParams error = RandomParams(rng);
  CurrentFieldParams wiring;
  WireSegment lead;
  lead.a_B_m = {-0.1, 0.03, 0.0};
  lead.b_B_m = {0.1, 0.03, 0.0};
  wiring.segments = {lead};
  const Eigen::Vector3d sensor_p_B_m(0.0, 0.0, -0.04);
  const Eigen::Matrix3d R_NB = QuatFromEuler(0.1, -0.2, 2.0).toRotationMatrix();
  const Eigen::Vector3d B_N_uT(25.5, -4.5, 48.2);
  const Currents currents{53.0, {}};
  const Eigen::Vector3d wire_uT = SegmentField_uT(lead.a_B_m, lead.b_B_m, 53.0, sensor_p_B_m);
  // Symmetric finite wire: |B| = μ0 I/(2π r)·L/√(L² + r²), r = 5 cm from the lead, half-length L = 10 cm
  // (≈ 190 µT: the wiring term is far from negligible, so the check below is not vacuous).
  const double r_m = 0.05, L_m = 0.1;
  EXPECT_NEAR(wire_uT.norm(), 2e-7 * 53.0 / r_m * L_m / std::hypot(L_m, r_m) * 1e6, 1e-9 * wire_uT.norm());
  const Eigen::Vector3d expected = ApplyCompassError(error, R_NB.transpose() * B_N_uT + wire_uT, 53.0);
  const Eigen::Vector3d reading =
      NoiselessCompassReading_uT(error, wiring, sensor_p_B_m, R_NB, B_N_uT, currents);
  EXPECT_LT((reading - expected).norm(), 1e-12 * expected.norm());
  // Motors off: only the Earth field, whose magnitude through an ideal sensor is the same in any attitude.
  const Eigen::Vector3d quiet = NoiselessCompassReading_uT(CompassErrorParams{}, wiring, sensor_p_B_m, R_NB, B_N_uT, {0.0, {}});
  EXPECT_NEAR(quiet.norm(), B_N_uT.norm(), 1e-12 * B_N_uT.norm());
}

}  // namespace
}  // namespace hexsim::magnetics
