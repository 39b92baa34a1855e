// The family-wise correction over a family's members (attribution.h EffectiveTests): members that
// are one regressor shifted by a fraction of its correlation time count as about one test; members
// with unrelated regressors count as many. And a norm's reported interval (Describe): it holds 0
// where the vector's 95 % region does.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "../src/attribution.h"
#include "../src/replay_util.h"
#include "hexsim/gap/diagnose.h"
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
  members.reserve(31);
  for (int s = 0; s <= 30; ++s) {
    std::vector<double> I;
    I.reserve(600);
    for (int k = 0; k < 600; ++k) {
      const double t = 0.1 * k + 0.025 * s;
      I.push_back(Current(t, noise[static_cast<size_t>(k) + static_cast<size_t>(s / 4)]));
    }
    members.push_back(HardIron(I));
  }
  std::vector<const Candidate*> ptr;
  ptr.reserve(members.size());
  for (const Candidate& c : members) ptr.push_back(&c);
  const double tests = EffectiveTests(ptr);
  // Bonferroni over 31 members would multiply the p-value by 31; they test one slow current.
  EXPECT_GE(tests, 1.0);
  EXPECT_LT(tests, 4.0) << tests;
}

TEST(GapEffectiveTests, GivenUnrelatedRegressors_WhenCounted_ThenEachIsATest) {
  RngStream rng(11, "effective_tests");
  std::vector<Candidate> members;
  members.reserve(6);
  for (int m = 0; m < 6; ++m) {
    std::vector<double> I;
    I.reserve(600);
    for (int k = 0; k < 600; ++k) I.push_back(rng.Normal());
    members.push_back(HardIron(I));
  }
  std::vector<const Candidate*> ptr;
  ptr.reserve(members.size());
  for (const Candidate& c : members) ptr.push_back(&c);
  EXPECT_GT(EffectiveTests(ptr), 5.0);
  EXPECT_LE(EffectiveTests(ptr), 6.0);
  EXPECT_EQ(EffectiveTests({ptr.front()}), 1.0);
}

// A current_hard_iron fit d·I over 12 blocks of 50 samples of white noise (σ 1), the current
// as above: the evaluation Describe reads (block normal equations, full fit).
Evaluated FitBlocks(const Candidate& c, const Vec3& d_true, RngStream* rng) {
  constexpr int kBlocks = 12, kPerBlock = 50;
  Evaluated e;
  e.cand = &c;
  Block all{Eigen::MatrixXd::Zero(3, 3), Eigen::VectorXd::Zero(3), 0, 0};
  for (int b = 0; b < kBlocks; ++b) {
    Block blk{Eigen::MatrixXd::Zero(3, 3), Eigen::VectorXd::Zero(3), 0, 0};
    for (int k = b * kPerBlock; k < (b + 1) * kPerBlock; ++k) {
      const Mat3X& x = c.X[static_cast<size_t>(k)];
      const Vec3 y = x * d_true + Vec3(rng->Normal(), rng->Normal(), rng->Normal());
      blk.A += x.transpose() * x;
      blk.g += x.transpose() * y;
      blk.s += y.squaredNorm();
      blk.n += 3;
    }
    all.A += blk.A;
    all.g += blk.g;
    e.blocks.push_back(blk);
  }
  e.full.beta = all.A.ldlt().solve(all.g);
  e.full.ok = true;
  return e;
}

TEST(GapNormInterval, GivenNoField_WhenTheNormIsDescribed_ThenItsIntervalHoldsZeroAsOftenAsItsLevel) {
  RngStream rng(5, "norm_interval");
  std::vector<double> I;
  I.reserve(600);
  for (int k = 0; k < 600; ++k) I.push_back(Current(0.1 * k, 0.0));
  const Candidate c = HardIron(I);
  constexpr int kTrials = 200;
  int holds_zero = 0;
  for (int trial = 0; trial < kTrials; ++trial) {
    const Evaluated e = FitBlocks(c, Vec3::Zero(), &rng);
    CandidateResult r;
    Describe(e, GridPicks{}, &r);
    holds_zero += r.magnitude_ci95[0] <= 0.0 ? 1 : 0;
  }
  // 95 % intervals: about 190 of 200 hold the true 0 (the delta method's |d| − t·sd alone: few).
  EXPECT_GE(holds_zero, 180) << holds_zero;
  // A resolved field keeps its delta-method interval, away from 0 and around the truth.
  const Vec3 d(0.2, -0.1, 0.05);
  const Evaluated e = FitBlocks(c, d, &rng);
  CandidateResult r;
  Describe(e, GridPicks{}, &r);
  EXPECT_GT(r.magnitude_ci95[0], 0.0);
  EXPECT_LE(r.magnitude_ci95[0], d.norm());
  EXPECT_GE(r.magnitude_ci95[1], d.norm());
}

}  // namespace
}  // namespace hexsim::gap::internal
