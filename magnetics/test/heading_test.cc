#include "hexsim/magnetics/heading.h"

#include <cmath>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "hexsim/common/rng.h"
#include "hexsim/common/rotation.h"
#include "hexsim/magnetics/wmm.h"

namespace hexsim::magnetics {
namespace {

TEST(Heading, GivenALevelVehicle_WhenPointingNorthOrEast_ThenHeadingIsZeroOrPlus90) {
  const double H = 20.0, Z = 45.0;
  EXPECT_NEAR(MagneticHeadingRad({H, 0.0, Z}, 0.0, 0.0), 0.0, 1e-15);
  // Facing east, magnetic north is on the vehicle's left (−y, body FRD).
  EXPECT_NEAR(MagneticHeadingRad({0.0, -H, Z}, 0.0, 0.0), kPi / 2, 1e-15);
  EXPECT_NEAR(std::abs(MagneticHeadingRad({-H, 0.0, Z}, 0.0, 0.0)), kPi, 1e-15);
}

TEST(Heading, GivenRandomAttitudes_WhenTheTrueFieldIsRotatedIntoBody_ThenTrueHeadingEqualsYaw) {
  // Property: m_B = R_NBᵀ·B_N, then ψ_mag + declination = yaw for every roll and any pitch short of ±90°.
  RngStream rng(31, "heading_property");
  const Result<EarthField> earth = EvaluateWmm({43.88, 125.35, 200.0}, 2016.5);
  ASSERT_TRUE(earth.ok());
  const double declination_rad = earth->declination_deg * kDegToRad;
  for (int k = 0; k < 2000; ++k) {
    const double roll = kPi * (2 * rng.Uniform() - 1);
    const double pitch = 80.0 * kDegToRad * (2 * rng.Uniform() - 1);
    const double yaw = kPi * (2 * rng.Uniform() - 1);
    const Eigen::Matrix3d R_NB = QuatFromEuler(roll, pitch, yaw).toRotationMatrix();
    const Eigen::Vector3d m_B = R_NB.transpose() * earth->B_N_uT;
    const double heading = TrueHeadingRad(m_B, roll, pitch, declination_rad);
    EXPECT_NEAR(WrapPi(heading - yaw), 0.0, 1e-9) << "roll " << roll << " pitch " << pitch << " yaw " << yaw;
    EXPECT_GT(heading, -kPi);
    EXPECT_LE(heading, kPi);
  }
}

TEST(Heading, GivenTiltCompensation_WhenApplied_ThenItRecoversTheLevelHorizontalComponents) {
  RngStream rng(33, "heading_tilt");
  const Eigen::Vector3d B_level(19.0, -4.0, 50.0);  // field in the yaw-only frame
  for (int k = 0; k < 100; ++k) {
    const double roll = kPi * (2 * rng.Uniform() - 1);
    const double pitch = 1.5 * (2 * rng.Uniform() - 1);
    const Eigen::Matrix3d R = QuatFromEuler(roll, pitch, 0.0).toRotationMatrix();
    const Eigen::Vector2d h = TiltCompensated(R.transpose() * B_level, roll, pitch);
    EXPECT_NEAR(h.x(), B_level.x(), 1e-12 * B_level.norm());
    EXPECT_NEAR(h.y(), B_level.y(), 1e-12 * B_level.norm());
  }
}

TEST(Heading, GivenDeclinationPushingPastPi_WhenTrueHeadingIsComputed_ThenItIsWrappedToMinusPiPi) {
  const double psi_mag = 170.0 * kDegToRad;
  const Eigen::Vector3d m_B(20.0 * std::cos(psi_mag), -20.0 * std::sin(psi_mag), 40.0);
  EXPECT_NEAR(TrueHeadingRad(m_B, 0.0, 0.0, 20.0 * kDegToRad), -170.0 * kDegToRad, 1e-12);
}

TEST(Heading, GivenSmallBodyFieldDisturbances_WhenFirstOrderErrorIsComparedWithExact_ThenTheyAgreeWithinTheSecondOrderBound) {
  // Level vehicle at heading ψ: m_B = (H_h cos ψ, −H_h sin ψ, Z). The exact error is
  // ψ(m + ΔH) − ψ(m); eq. 9 is its linearisation. ψ = atan2(−Y, X) has a Hessian of norm 1/ρ², ρ the
  // horizontal magnitude, so the Taylor remainder is ≤ ½·|ΔH_h|² / (H_h − |ΔH_h|)².
  const Result<EarthField> earth = EvaluateWmm({43.88, 125.35, 200.0}, 2016.5);
  ASSERT_TRUE(earth.ok());
  const double H_h = earth->horizontal_uT;
  const double incl = earth->inclination_deg * kDegToRad;
  RngStream rng(37, "heading_first_order");
  double largest_error = 0.0;
  for (double relative : {1e-3, 1e-2, 3e-2}) {
    for (int k = 0; k < 200; ++k) {
      const double psi = kPi * (2 * rng.Uniform() - 1);
      const Eigen::Vector3d m_B(H_h * std::cos(psi), -H_h * std::sin(psi), earth->B_N_uT.z());
      const Eigen::Vector3d dH = relative * H_h * rng.Normal3(1.0).normalized();
      const double exact = WrapPi(MagneticHeadingRad(m_B + dH, 0.0, 0.0) - MagneticHeadingRad(m_B, 0.0, 0.0));
      const double first = FirstOrderHeadingErrorRad(dH, psi, H_h, incl);
      const double dh = dH.head<2>().norm();
      const double bound = 0.5 * dh * dh / ((H_h - dh) * (H_h - dh));
      EXPECT_LE(std::abs(exact - first), bound + 1e-15) << "relative " << relative << " psi " << psi;
      largest_error = std::max(largest_error, std::abs(exact));
    }
  }
  // The test is not vacuous: the disturbances produced errors far above the bounds.
  EXPECT_GT(largest_error, 0.01);
}

TEST(Heading, GivenAVerticalDisturbanceOnALevelVehicle_WhenFirstOrderErrorIsComputed_ThenItIsZero) {
  EXPECT_EQ(FirstOrderHeadingErrorRad({0.0, 0.0, 5.0}, 0.7, 20.0, 1.1), 0.0);
}

}  // namespace
}  // namespace hexsim::magnetics
