// The family-wise correction over a family's members (attribution.h EffectiveTests): members that
// are one regressor shifted by a fraction of its correlation time count as about one test; members
// with unrelated regressors count as many.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "../src/attribution.h"
#include "../src/replay_util.h"
#include "hexsim/common/rng.h"
#include "hexsim/common/rotation.h"

namespace hexsim::gap::internal {
namespace {

// A 10 Hz, 60 s battery current: hover with slow manoeuvres (periods 7-25 s) and sensor noise.
double Current(double t, double noise) {
  return 15.0 + 4.0 * std::sin(2 * kPi * t / 25.0) + 2.5 * std::sin(2 * kPi * t / 7.0 + 1.0) + noise;
}

Candidate HardIron(const std::vector<double>& I) {
  Candidate c = MakeCandidate("current_hard_iron", {"d_x_uT_per_A", "d_y_uT_per_A", "d_z_uT_per_A"}, {1, 1, 1}, "uT/A");
  for (double x : I) c.X.push_back(Diag3(x));
  return c;
}

TEST(GapEffectiveTests, GivenACurrentShiftedInQuarterUpdatePeriods_WhenCounted_ThenTheMembersAreAboutOneTest) {
  RngStream rng(7, "effective_tests");
  std::vector<double> noise(700);
  for (double& x : noise) x = 0.1 * rng.Normal();
  // The aligned members: the current 0..0.75 s later in 25 ms steps (AlignedMemberShifts' grid on a
  // 10 Hz current), 31 members.
  std::vector<Candidate> members;
  for (int s = 0; s <= 30; ++s) {
    std::vector<double> I;
    for (int k = 0; k < 600; ++k) {
      const double t = 0.1 * k + 0.025 * s;
      I.push_back(Current(t, noise[static_cast<size_t>(k + s / 4)]));
    }
    members.push_back(HardIron(I));
  }
  std::vector<const Candidate*> ptr;
  for (const Candidate& c : members) ptr.push_back(&c);
  const double tests = EffectiveTests(ptr);
  // Bonferroni over 31 members would multiply the p-value by 31; they test one slow current.
  EXPECT_GE(tests, 1.0);
  EXPECT_LT(tests, 4.0) << tests;
}

TEST(GapEffectiveTests, GivenUnrelatedRegressors_WhenCounted_ThenEachIsATest) {
  RngStream rng(11, "effective_tests");
  std::vector<Candidate> members;
  for (int m = 0; m < 6; ++m) {
    std::vector<double> I;
    for (int k = 0; k < 600; ++k) I.push_back(rng.Normal());
    members.push_back(HardIron(I));
  }
  std::vector<const Candidate*> ptr;
  for (const Candidate& c : members) ptr.push_back(&c);
  EXPECT_GT(EffectiveTests(ptr), 5.0);
  EXPECT_LE(EffectiveTests(ptr), 6.0);
  EXPECT_EQ(EffectiveTests({ptr.front()}), 1.0);
}

}  // namespace
}  // namespace hexsim::gap::internal
