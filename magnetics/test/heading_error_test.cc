#include "hexsim/magnetics/heading_error.h"

#include <cmath>

#include <gtest/gtest.h>

#include "hexsim/common/rng.h"
#include "hexsim/common/rotation.h"
#include "hexsim/magnetics/compensators.h"
#include "support/calib_synth.h"

namespace hexsim::magnetics {
namespace {

using Eigen::Vector3d;

struct Fixture {
  testing::SynthRig rig;
  std::vector<MagSample> samples;
  double B_h_uT = 0.0;
  // Per-sample heading noise (deg) of a reading with noise σ on a horizontal field B_h: σ/B_h.
  double noise_deg = 0.0;
};

Fixture MakeFixture(uint64_t seed) {
  Fixture f;
  f.rig.soft_iron = testing::TestSoftIron();
  RngStream rng(seed, "heading_error_test");
  f.samples = testing::Turntable(f.rig, rng);
  f.B_h_uT = f.rig.earth_N_uT.head<2>().norm();
  f.noise_deg = f.rig.noise_uT / f.B_h_uT * kRadToDeg;
  return f;
}

std::unique_ptr<Compensator> Learn(const std::string& method, const std::vector<MagSample>& s) {
  auto r = LearnCompensator(method, s, LearnOptions{}, nullptr);
  EXPECT_TRUE(r.ok()) << r.status().message();
  return std::move(r).value();
}

// A body-fixed error field δ on a level turn tilts the horizontal field by at most asin(|δ_xy|/B_h).
double ExpectedMaxDeg(const Fixture& f, const Vector3d& delta_B_uT) {
  return std::asin(delta_B_uT.head<2>().norm() / f.B_h_uT) * kRadToDeg;
}

TEST(HeadingError, GivenAHardIronLineInControl_WhenTraditionalCorrects_ThenHeadingErrorGrowsWithControlAsPredicted) {
  const Fixture f = MakeFixture(1);
  const auto c = Learn("traditional", f.samples);
  const auto rows = EvaluateHeadingError(*c, f.samples, HeadingErrorOptions{});
  ASSERT_TRUE(rows.ok()) << rows.status().message();
  ASSERT_EQ(rows->size(), 3u);
  for (const auto& row : *rows) {
    // The ground fit removes β(0); what remains at control u is K⁻¹·u·d in the corrected frame.
    const Vector3d delta = f.rig.soft_iron.inverse() * (row.control_u * f.rig.d_uT_per_u);
    const double expected = ExpectedMaxDeg(f, delta);
    // Max of 36 noisy samples: up to 4σ; 10° table steps can miss the peak by 1 − cos 5° ≈ 0.4 %.
    const double tol = 4.0 * f.noise_deg + 0.01 * expected;
    EXPECT_NEAR(row.max_abs_deg, expected, tol) << "control " << row.control_u;
    EXPECT_EQ(row.num_samples, 36);
    EXPECT_LE(row.rms_deg, row.max_abs_deg);
  }
  EXPECT_LT((*rows)[0].max_abs_deg, (*rows)[1].max_abs_deg);
  EXPECT_LT((*rows)[1].max_abs_deg, (*rows)[2].max_abs_deg);
}

TEST(HeadingError, GivenAHardIronLineInControl_WhenAdaptiveMethodsCorrect_ThenHeadingErrorStaysAtTheNoiseLevel) {
  const Fixture f = MakeFixture(2);
  for (const char* method : {"adaptive", "adaptive-current", "compassmot", "px4-ls"}) {
    const auto c = Learn(method, f.samples);
    const auto rows = EvaluateHeadingError(*c, f.samples, HeadingErrorOptions{});
    ASSERT_TRUE(rows.ok()) << rows.status().message();
    for (const auto& row : *rows) {
      EXPECT_LT(row.max_abs_deg, 4.0 * f.noise_deg) << method << " control " << row.control_u;
      EXPECT_LT(row.rms_deg, 2.0 * f.noise_deg) << method << " control " << row.control_u;
    }
  }
}

TEST(HeadingError, GivenNoCorrection_WhenEvaluated_ThenTheGroundHardIronDominatesTheError) {
  const Fixture f = MakeFixture(3);
  const auto rows = EvaluateHeadingError(*MakeNoneCompensator(), f.samples, HeadingErrorOptions{});
  ASSERT_TRUE(rows.ok());
  // Soft iron also distorts the heading, so only a lower bound from the hard iron alone, less the
  // largest soft-iron tilt (|K − I| ≈ 6 % → ≈ 3.5°).
  const double hard_only = ExpectedMaxDeg(f, f.rig.hard_iron0_uT);
  EXPECT_GT((*rows)[0].max_abs_deg, hard_only - 4.0);
}

TEST(HeadingError, GivenAnIncompleteTurn_WhenEvaluated_ThenBadInput) {
  Fixture f = MakeFixture(4);
  std::vector<MagSample> half;
  for (const auto& s : f.samples) {
    if (s.angle_deg < 180.0) half.push_back(s);
  }
  const auto rows = EvaluateHeadingError(*MakeNoneCompensator(), half, HeadingErrorOptions{});
  EXPECT_EQ(rows.status().code(), StatusCode::kBadInput);
  EXPECT_NE(rows.status().message().find("full turn"), std::string::npos) << rows.status().message();
}

TEST(HeadingError, GivenSamplesWithoutTheTrueEarthField_WhenEvaluated_ThenBadInput) {
  Fixture f = MakeFixture(5);
  for (auto& s : f.samples) s.earth_B_uT.setZero();
  EXPECT_EQ(EvaluateHeadingError(*MakeNoneCompensator(), f.samples, HeadingErrorOptions{}).status().code(),
            StatusCode::kBadInput);
}

TEST(HeadingError, GivenAKnownBodyFieldError_WhenOneSampleIsEvaluated_ThenTheErrorIsTheExactAngle) {
  // Level, heading 0: earth field along body x; a +y error field of B_h·tan(10°) puts north to the
  // right of the nose, so the reading says the nose points 10° west: ψ_mag = −10°.
  MagSample s;
  s.plane = "xy";
  s.earth_B_uT = Vector3d(20.0, 0.0, 40.0);
  s.mag_B_uT = s.earth_B_uT + Vector3d(0.0, 20.0 * std::tan(10.0 * kDegToRad), 0.0);
  EXPECT_NEAR(SampleHeadingErrorDeg(*MakeNoneCompensator(), s), -10.0, 1e-9);
}

}  // namespace
}  // namespace hexsim::magnetics
