// The current-driven families' aligned members: the current's staleness profiled on the compass
// itself, around what the throttle scan read (channels.h AlignedMemberShifts).
#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "../src/channels.h"
#include "../src/selftest_real.h"
#include "hexsim/common/rng.h"
#include "support/gap_fixtures.h"

namespace hexsim::gap {
namespace {

realdata::LagEstimate Staleness(double value_s, double lo_s, double hi_s) {
  realdata::LagEstimate s;
  s.value_s = value_s;
  s.ci95_s[0] = lo_s;
  s.ci95_s[1] = hi_s;
  return s;
}

internal::LogInputs FiveHzCurrent() {
  internal::LogInputs in;
  for (int k = 0; k < 50; ++k) in.current_samples_t.push_back(0.2 * k);
  return in;
}

TEST(GapCurrentAlignment, GivenAResolvedStaleness_WhenShiftsAreMade_ThenTheyCoverItsIntervalWidenedByTheUpdatePeriod) {
  const std::vector<double> s = internal::AlignedMemberShifts(Staleness(0.171, 0.142, 0.230), FiveHzCurrent());
  ASSERT_FALSE(s.empty());
  EXPECT_TRUE(std::is_sorted(s.begin(), s.end()));
  // [0.142 − 0.2 → 0, 0.230 + 0.2] in quarter periods (50 ms), the scan's estimate among them.
  EXPECT_DOUBLE_EQ(s.front(), 0.0);
  EXPECT_NEAR(s.back(), 0.4, 1e-9);
  EXPECT_NE(std::find(s.begin(), s.end(), 0.171), s.end());
  for (size_t k = 1; k < s.size(); ++k) EXPECT_LE(s[k] - s[k - 1], 0.05 + 1e-9);
  // Never past the staleness's physical range (plausibility row current_staleness, 0..1 s).
  const std::vector<double> late = internal::AlignedMemberShifts(Staleness(0.95, 0.9, 0.99), FiveHzCurrent());
  ASSERT_FALSE(late.empty());
  EXPECT_LE(late.back(), 1.0 + 1e-9);
  // No resolved staleness: no aligned members beyond the logged current.
  EXPECT_TRUE(internal::AlignedMemberShifts(realdata::LagEstimate(), FiveHzCurrent()).empty());
}

// A real-profile flight whose 5 Hz current is 248 ms stale: the scan against the throttle reads
// 171 ms [142, 230], and the current aligned by it carries the field 77 ms late, so the fresh
// throttle's square fitted it better (throttle_hard_iron, the one-effect miss of the selftest).
// Aligned on the compass the current lands on the staleness and is named.
TEST(GapCurrentAlignment, GivenAStaleCurrentTheThrottleScanReadsShort_WhenDiagnosed_ThenTheCurrentIsAlignedOnTheCompassAndNamed) {
  constexpr uint64_t kSeed = 1207;
  RngStream rng(kSeed, "real_profile_test");
  const double injected = 0.2 + 0.6 * rng.Uniform();
  SelftestOptions so;
  so.mission = "selftest_flight";
  auto trial = MakeTrial(so, kSeed, {{"current_hard_iron", injected}}, &rng);
  ASSERT_TRUE(trial.ok()) << trial.status().message();
  auto flown = FlyTrial(&*trial, &rng);
  ASSERT_TRUE(flown.ok()) << flown.status().message();
  internal::RealLogTruth lt;
  auto log = internal::DegradeToRealLog(*flown, trial->configured, &rng, &lt);
  ASSERT_TRUE(log.ok()) << log.status().message();
  DiagnoseOptions opt;
  opt.channels = {"mag2"};
  opt.compass_latency_s = lt.latency_s;
  auto rep = Diagnose(*log, trial->configured, opt);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr) << Summary(*rep);
  // The case: the throttle scan reads the staleness short by more than a quarter update period.
  ASSERT_TRUE(mag2->timing.current_staleness.present);
  ASSERT_LT(mag2->timing.current_staleness.value_s, lt.staleness_s - 0.05) << Summary(*rep);
  EXPECT_EQ(mag2->verdict, "current_hard_iron") << Summary(*rep);
  const CandidateResult* chi = gaptest::FindCandidate(*mag2, "current_hard_iron");
  ASSERT_NE(chi, nullptr) << Summary(*rep);
  // Aligned within half the current's update period (0.1 s) of the injected staleness.
  ASSERT_EQ(chi->params.count("current_aligned"), 1u);
  EXPECT_NEAR(chi->params.at("current_aligned"), lt.staleness_s, 0.1) << Summary(*rep);
  const double truth = trial->true_magnitude[0] * (1 + lt.scale);
  EXPECT_LE(chi->magnitude_ci95[0], truth) << Summary(*rep);
  EXPECT_GE(chi->magnitude_ci95[1], truth) << Summary(*rep);
}

}  // namespace
}  // namespace hexsim::gap
