#include "hexsim/magnetics/current_field.h"

#include <cmath>
#include <utility>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "hexsim/common/rng.h"

namespace hexsim::magnetics {
namespace {

constexpr double kMu0_TmpA = 4e-7 * 3.14159265358979323846;  // μ0 with μ0/(4π) = 1e-7 exactly
constexpr double kUtPerT = 1e6;

Eigen::Vector3d RandomPoint(RngStream& rng, double half_width_m) {
  return {half_width_m * (2 * rng.Uniform() - 1), half_width_m * (2 * rng.Uniform() - 1),
          half_width_m * (2 * rng.Uniform() - 1)};
}

TEST(SegmentField, GivenAVeryLongSegment_WhenFieldIsTakenNearItsMiddle_ThenItIsTheInfiniteWireFieldAroundTheWire) {
  // Current 30 A along +x from −L to +L; point at distance r on +y.
  const double I_A = 30.0, r_m = 0.05, L_m = 1000.0;
  const Eigen::Vector3d B = SegmentField_uT({-L_m, 0, 0}, {L_m, 0, 0}, I_A, {0, r_m, 0});
  const double infinite_uT = kMu0_TmpA * I_A / (2 * 3.14159265358979323846 * r_m) * kUtPerT;
  // Finite wire: B = μ0 I/(2π r)·L/√(L² + r²): relative deficit r²/(2L²) ≈ 1.3e-9.
  EXPECT_NEAR(B.norm(), infinite_uT, infinite_uT * 1e-8);
  // Right-hand rule: current along +x, point on +y → field along +z.
  EXPECT_NEAR(B.z(), infinite_uT, infinite_uT * 1e-8);
  EXPECT_NEAR(B.x(), 0.0, infinite_uT * 1e-12);
  EXPECT_NEAR(B.y(), 0.0, infinite_uT * 1e-12);
}

TEST(SegmentField, GivenAnObliqueSegment_WhenComparedWithNumericalBiotSavartIntegration_ThenTheyAgree) {
  // Independent check of the closed form: midpoint rule on dB = μ0 I/(4π) dl × r / |r|³.
  RngStream rng(7, "segment_quadrature");
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::Vector3d a = RandomPoint(rng, 0.2), b = RandomPoint(rng, 0.2), p = RandomPoint(rng, 0.3);
    const double I_A = 20.0;
    const int steps = 20000;
    const Eigen::Vector3d dl = (b - a) / steps;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int k = 0; k < steps; ++k) {
      const Eigen::Vector3d r = p - (a + (k + 0.5) * dl);
      sum += dl.cross(r) / std::pow(r.norm(), 3);
    }
    const Eigen::Vector3d numeric_uT = 1e-7 * I_A * sum * kUtPerT;
    const Eigen::Vector3d closed_uT = SegmentField_uT(a, b, I_A, p);
    // Midpoint error ~ (h/d)²/24 relative with h = |b − a|/steps, d the distance to the wire: far below 1e-6
    // unless p is within millimetres of the wire.
    EXPECT_LT((numeric_uT - closed_uT).norm(), 1e-6 * closed_uT.norm() + 1e-12) << "trial " << trial;
  }
}

TEST(SegmentField, GivenASegmentSplitInTwo_WhenFieldsAreSummed_ThenTheyEqualTheWholeSegment) {
  RngStream rng(11, "segment_split");
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Vector3d a = RandomPoint(rng, 0.3), b = RandomPoint(rng, 0.3), p = RandomPoint(rng, 0.3);
    const Eigen::Vector3d mid = a + rng.Uniform() * (b - a);
    const Eigen::Vector3d whole = SegmentField_uT(a, b, 12.5, p);
    const Eigen::Vector3d parts = SegmentField_uT(a, mid, 12.5, p) + SegmentField_uT(mid, b, 12.5, p);
    EXPECT_LT((whole - parts).norm(), 1e-10 * whole.norm()) << "trial " << trial;
  }
}

TEST(SegmentField, GivenAnyPoint_WhenFieldIsComputed_ThenItHasNoComponentAlongTheSegment) {
  RngStream rng(13, "segment_perp");
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Vector3d a = RandomPoint(rng, 0.3), b = RandomPoint(rng, 0.3), p = RandomPoint(rng, 0.3);
    const Eigen::Vector3d B = SegmentField_uT(a, b, -8.0, p);
    const Eigen::Vector3d u = (b - a).normalized();
    EXPECT_LT(std::abs(B.dot(u)), 1e-12 * B.norm()) << "trial " << trial;
    // Nor along the perpendicular from the wire to the point: B is azimuthal.
    const Eigen::Vector3d r1 = p - a;
    const Eigen::Vector3d radial = (r1 - r1.dot(u) * u).normalized();
    EXPECT_LT(std::abs(B.dot(radial)), 1e-12 * B.norm()) << "trial " << trial;
  }
}

TEST(SegmentField, GivenCurrentScaledOrReversed_WhenFieldIsComputed_ThenItScalesLinearly) {
  const Eigen::Vector3d a(0.1, -0.05, 0.02), b(-0.12, 0.07, 0.01), p(0.03, 0.04, -0.05);
  const Eigen::Vector3d B1 = SegmentField_uT(a, b, 1.0, p);
  ASSERT_GT(B1.norm(), 0.0);
  for (double I_A : {-53.0, 0.0, 0.5, 32.0}) {
    EXPECT_LT((SegmentField_uT(a, b, I_A, p) - I_A * B1).norm(), 1e-12 * std::abs(I_A) * B1.norm() + 1e-300);
  }
  // Reversing the segment is reversing the current.
  EXPECT_LT((SegmentField_uT(b, a, 1.0, p) + B1).norm(), 1e-12 * B1.norm());
}

TEST(SegmentField, GivenAPointOnTheSegmentsLine_WhenOutsideTheSegment_ThenTheFieldIsZero) {
  const Eigen::Vector3d B = SegmentField_uT({0, 0, 0}, {0.1, 0, 0}, 40.0, {0.3, 0, 0});
  EXPECT_EQ(B, Eigen::Vector3d::Zero());
}

TEST(DipoleField, GivenASmallSquareLoopFarAway_WhenComparedWithItsDipole_ThenTheyAgreeToSecondOrderInSizeOverDistance) {
  // Square of side s in the x-y plane, counter-clockwise seen from +z: moment I·s²·ẑ.
  const double s_m = 0.01, h = s_m / 2, I_A = 5.0;
  const Eigen::Vector3d c(0.02, -0.01, 0.03);  // loop centre
  const Eigen::Vector3d corners[4] = {c + Eigen::Vector3d(h, -h, 0), c + Eigen::Vector3d(h, h, 0),
                                      c + Eigen::Vector3d(-h, h, 0), c + Eigen::Vector3d(-h, -h, 0)};
  const Eigen::Vector3d moment_Am2 = I_A * s_m * s_m * Eigen::Vector3d::UnitZ();
  RngStream rng(17, "loop_dipole");
  for (double d_m : {0.2, 0.5}) {
    for (int trial = 0; trial < 10; ++trial) {
      const Eigen::Vector3d dir = rng.Normal3(1.0).normalized();
      const Eigen::Vector3d p = c + d_m * dir;
      Eigen::Vector3d loop = Eigen::Vector3d::Zero();
      for (int k = 0; k < 4; ++k) loop += SegmentField_uT(corners[k], corners[(k + 1) % 4], I_A, p);
      const Eigen::Vector3d dipole = DipoleField_uT(moment_Am2, c, p);
      // The loop's next multipole (a symmetric square has no quadrupole) is smaller by ~(s/d)²;
      // |B_dipole| ≥ μ0 m/(4π d³) in every direction, so bound the difference by 3(s/d)²·that scale.
      const double scale_uT = kMu0Over4Pi_uTmpA * moment_Am2.norm() / std::pow(d_m, 3);
      const double ratio2 = (s_m / d_m) * (s_m / d_m);
      EXPECT_LT((loop - dipole).norm(), 3.0 * ratio2 * scale_uT) << "d " << d_m << " trial " << trial;
      EXPECT_GT(dipole.norm(), 0.9 * scale_uT);
    }
  }
}

TEST(DipoleField, GivenAPointOnTheAxisAndOnTheEquator_WhenComputed_ThenFieldsAreTwiceAndMinusOnceMuOverR3) {
  const Eigen::Vector3d m(0, 0, 2.0);
  const double r_m = 0.1;
  const double unit_uT = kMu0Over4Pi_uTmpA * 2.0 / std::pow(r_m, 3);
  const Eigen::Vector3d axis = DipoleField_uT(m, Eigen::Vector3d::Zero(), {0, 0, r_m});
  const Eigen::Vector3d equator = DipoleField_uT(m, Eigen::Vector3d::Zero(), {r_m, 0, 0});
  EXPECT_LT((axis - Eigen::Vector3d(0, 0, 2 * unit_uT)).norm(), 1e-12 * unit_uT);
  EXPECT_LT((equator - Eigen::Vector3d(0, 0, -unit_uT)).norm(), 1e-12 * unit_uT);
}

CurrentFieldParams TwoSourceLayout() {
  CurrentFieldParams p;
  WireSegment lead;
  lead.a_B_m = {-0.10, 0.02, 0.01};
  lead.b_B_m = {0.10, 0.02, 0.01};
  lead.source = CurrentSource::kBattery;
  lead.name = "battery_positive";
  WireSegment ret = lead;
  ret.a_B_m = {0.10, 0.03, 0.01};
  ret.b_B_m = {-0.10, 0.03, 0.01};
  ret.name = "battery_negative";
  WireSegment esc;
  esc.a_B_m = {0.0, 0.0, 0.02};
  esc.b_B_m = {0.2, 0.15, 0.02};
  esc.source = CurrentSource::kMotor;
  esc.motor_index = 1;
  esc.share = 1.0;
  esc.name = "esc2_supply";
  p.segments = {lead, ret, esc};
  MotorDipole dip;
  dip.motor_index = 0;
  dip.p_B_m = {0.3, 0.0, -0.05};
  dip.moment_per_A_Am2 = {0.0, 0.0, 0.01};
  p.dipoles = {dip};
  return p;
}

TEST(CurrentDrivenField, GivenSeveralSources_WhenEvaluated_ThenItIsTheSumOfEachSegmentAndDipole) {
  const CurrentFieldParams p = TwoSourceLayout();
  ASSERT_TRUE(ValidateCurrentFieldParams(p, 2).ok());
  const Eigen::Vector3d sensor(0.0, 0.05, -0.03);
  const Currents I{20.0, {7.0, 9.0}};
  const Eigen::Vector3d expected = SegmentField_uT(p.segments[0].a_B_m, p.segments[0].b_B_m, 20.0, sensor) +
                                   SegmentField_uT(p.segments[1].a_B_m, p.segments[1].b_B_m, 20.0, sensor) +
                                   SegmentField_uT(p.segments[2].a_B_m, p.segments[2].b_B_m, 9.0, sensor) +
                                   DipoleField_uT(7.0 * p.dipoles[0].moment_per_A_Am2, p.dipoles[0].p_B_m, sensor);
  const Eigen::Vector3d B = CurrentDrivenField_uT(p, sensor, I);
  EXPECT_LT((B - expected).norm(), 1e-12 * expected.norm());
}

TEST(CurrentDrivenField, GivenAllCurrentsScaled_WhenEvaluated_ThenFieldScalesLinearlyAndEachSourceIsSelective) {
  const CurrentFieldParams p = TwoSourceLayout();
  const Eigen::Vector3d sensor(0.0, 0.05, -0.03);
  const Eigen::Vector3d B1 = CurrentDrivenField_uT(p, sensor, {10.0, {3.0, 4.0}});
  const Eigen::Vector3d B3 = CurrentDrivenField_uT(p, sensor, {30.0, {9.0, 12.0}});
  EXPECT_LT((B3 - 3.0 * B1).norm(), 1e-12 * B3.norm());
  // Only motor 1's current reaches the ESC-2 segment; motor 0 drives only the dipole.
  const Eigen::Vector3d only_m1 = CurrentDrivenField_uT(p, sensor, {0.0, {0.0, 4.0}});
  EXPECT_LT((only_m1 - SegmentField_uT(p.segments[2].a_B_m, p.segments[2].b_B_m, 4.0, sensor)).norm(),
            1e-12 * only_m1.norm());
  EXPECT_EQ(CurrentDrivenField_uT(p, sensor, {0.0, {0.0, 0.0}}), Eigen::Vector3d::Zero());
}

TEST(CurrentDrivenField, GivenANegativeShare_WhenEvaluated_ThenItEqualsTheReversedSegment) {
  WireSegment a_to_b;
  a_to_b.a_B_m = {0.0, 0.0, 0.0};
  a_to_b.b_B_m = {0.1, 0.05, 0.0};
  a_to_b.share = -1.0;
  WireSegment b_to_a = a_to_b;
  std::swap(b_to_a.a_B_m, b_to_a.b_B_m);
  b_to_a.share = 1.0;
  CurrentFieldParams forward, reversed;
  forward.segments = {a_to_b};
  reversed.segments = {b_to_a};
  const Eigen::Vector3d sensor(0.02, 0.08, -0.02);
  const Currents I{15.0, {}};
  EXPECT_LT((CurrentDrivenField_uT(forward, sensor, I) - CurrentDrivenField_uT(reversed, sensor, I)).norm(), 1e-12);
}

TEST(CurrentDrivenField, GivenANonPhysicalExponent_WhenCurrentDoubles_ThenFieldGrowsByTwoToThatPower) {
  CurrentFieldParams p = TwoSourceLayout();
  p.exponent = 1.5;
  const Eigen::Vector3d sensor(0.0, 0.05, -0.03);
  const Eigen::Vector3d B1 = CurrentDrivenField_uT(p, sensor, {10.0, {3.0, 4.0}});
  const Eigen::Vector3d B2 = CurrentDrivenField_uT(p, sensor, {20.0, {6.0, 8.0}});
  EXPECT_LT((B2 - std::pow(2.0, 1.5) * B1).norm(), 1e-12 * B2.norm());
}

TEST(CurrentDrivenField, GivenAMotorIndexBeyondTheMotorCount_WhenValidated_ThenBadInputNamesTheSegment) {
  const CurrentFieldParams p = TwoSourceLayout();
  const Status s = ValidateCurrentFieldParams(p, 1);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.code(), StatusCode::kBadInput);
  EXPECT_NE(s.message().find("esc2_supply"), std::string::npos) << s.message();
  CurrentFieldParams bad_tau = TwoSourceLayout();
  bad_tau.lag_tau_s = -0.1;
  EXPECT_EQ(ValidateCurrentFieldParams(bad_tau, 2).code(), StatusCode::kBadInput);
}

TEST(CurrentLag, GivenAStepInCurrent_WhenOneTimeConstantHasPassed_ThenTheFilteredCurrentHasReached63Percent) {
  CurrentFieldParams p;
  p.lag_tau_s = 0.05;
  const double dt_s = 0.001;
  CurrentLagState state;
  StepCurrentLag(p, {0.0, {0.0, 0.0}}, dt_s, &state);  // starts at rest
  const Currents step{40.0, {10.0, 20.0}};
  const int steps_per_tau = 50;
  Currents out;
  for (int k = 0; k < steps_per_tau; ++k) out = StepCurrentLag(p, step, dt_s, &state);
  // Exact discretisation: 1 − e^(−n·dt/τ) = 1 − e^(−1) after n·dt = τ, to rounding.
  const double fraction = 1.0 - std::exp(-1.0);
  EXPECT_NEAR(out.battery_A, 40.0 * fraction, 1e-9);
  EXPECT_NEAR(out.motor_A[0], 10.0 * fraction, 1e-9);
  EXPECT_NEAR(out.motor_A[1], 20.0 * fraction, 1e-9);
  // The same time in one big step gives the same answer (exactness, not Euler).
  CurrentLagState coarse;
  StepCurrentLag(p, {0.0, {0.0, 0.0}}, dt_s, &coarse);
  EXPECT_NEAR(StepCurrentLag(p, step, p.lag_tau_s, &coarse).battery_A, 40.0 * fraction, 1e-9);
}

TEST(CurrentLag, GivenNoLagOrAFirstCall_WhenStepped_ThenTheInputPassesThrough) {
  CurrentFieldParams no_lag;
  CurrentLagState s1;
  StepCurrentLag(no_lag, {1.0, {2.0}}, 0.001, &s1);
  EXPECT_EQ(StepCurrentLag(no_lag, {5.0, {6.0}}, 0.001, &s1).battery_A, 5.0);
  CurrentFieldParams lag;
  lag.lag_tau_s = 0.2;
  CurrentLagState s2;
  const Currents& first = StepCurrentLag(lag, {7.0, {8.0, 9.0}}, 0.001, &s2);
  EXPECT_EQ(first.battery_A, 7.0);
  EXPECT_EQ(first.motor_A[1], 9.0);
  EXPECT_TRUE(s2.initialised);
}

}  // namespace
}  // namespace hexsim::magnetics
