// The family-wise correction over a family's members (attribution.h EffectiveTests): members that
// are one regressor shifted by a fraction of its correlation time count as about one test; members
// with unrelated regressors count as many. And a norm's reported interval (Describe): it holds 0
// where the vector's 95 % region does.
#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Eigenvalues>

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

// The count from the members' correlation matrix formed directly: every signature stacked into one
// 3n × members matrix, centred, its columns normalised, Sᵀ·S (the definition EffectiveTests sums in
// chunks of samples).
double DirectCount(const std::vector<const Candidate*>& members) {
  const size_t n = members.front()->X.size();
  Eigen::MatrixXd S(3 * static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(members.size()));
  for (size_t m = 0; m < members.size(); ++m) {
    for (size_t i = 0; i < n; ++i) {
      S.block(3 * static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(m), 3, 1) = members[m]->X[i].rowwise().sum();
    }
  }
  S.rowwise() -= S.colwise().mean();
  const Eigen::VectorXd norm = S.colwise().norm();
  S = S * norm.cwiseInverse().asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(S.transpose() * S, Eigen::EigenvaluesOnly);
  double tests = 0;
  for (Eigen::Index i = 0; i < eig.eigenvalues().size(); ++i) {
    const double l = std::fabs(eig.eigenvalues()[i]);
    tests += (l >= 1.0 ? 1.0 : 0.0) + (l - std::floor(l));
  }
  return std::clamp(tests, 1.0, static_cast<double>(members.size()));
}

// Samples that do not fill the last chunk, members of two and three columns and axis-uniform ones
// (a regressor times the identity), partly correlated: the chunked, split sums give the direct count.
TEST(GapEffectiveTests, GivenMembersOverSeveralChunksOfSamples_WhenCounted_ThenTheCountIsTheDirectOne) {
  RngStream rng(13, "effective_tests");
  constexpr int kSamples = 1000;  // 15 chunks of 64 samples and 40 over
  std::vector<double> common(kSamples);
  for (double& x : common) x = rng.Normal();
  std::vector<Candidate> members;
  members.reserve(7);
  for (int m = 0; m < 7; ++m) {
    Candidate c = MakeCandidate("current_soft_iron", {"a", "b"}, {1, 1}, "1");
    for (int k = 0; k < kSamples; ++k) {
      const double u = (1.0 + m) * common[static_cast<size_t>(k)] + 3.0;
      if (m % 3 == 0) {  // axis-uniform: a regressor times the identity
        c.X.push_back(Diag3(u + 0.5 * rng.Normal()));
        continue;
      }
      Mat3X x(3, m % 2 == 0 ? 2 : 3);
      x.setZero();
      for (Eigen::Index j = 0; j < x.cols(); ++j) x(j, j) = u + 0.5 * rng.Normal();
      c.X.push_back(x);
    }
    members.push_back(std::move(c));
  }
  std::vector<const Candidate*> ptr;
  ptr.reserve(members.size());
  for (const Candidate& c : members) ptr.push_back(&c);
  const double direct = DirectCount(ptr);
  EXPECT_NEAR(EffectiveTests(ptr), direct, 1e-9);
  EXPECT_GT(direct, 1.5);
  EXPECT_LT(direct, 6.9);
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
