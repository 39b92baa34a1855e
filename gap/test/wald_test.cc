// The cluster-robust Wald test of gap's attribution: F with G − q degrees of freedom, and "not
// testable" (p = 1) where the parameters outnumber the blocks.
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "../src/attribution.h"

namespace hexsim::gap::internal {
namespace {

// A covariance built as the sum of G block scores has rank ≤ G: a short log (few blocks) and a
// many-parameter candidate (per-motor: 12).
Eigen::MatrixXd BlockCov(int q, int G) {
  Eigen::MatrixXd S = Eigen::MatrixXd::Zero(q, q);
  for (int g = 0; g < G; ++g) {
    Eigen::VectorXd s(q);
    for (int i = 0; i < q; ++i) s[i] = std::sin(1.0 + 0.7 * g + 1.3 * i);
    S += s * s.transpose();
  }
  return S;
}

TEST(WaldTest, GivenMoreParametersThanBlocksWhenTestedThenNotTestable) {
  const int q = 9, G = 4;
  Eigen::VectorXd beta = Eigen::VectorXd::Constant(q, 0.01);  // a tiny effect
  // Before: the chi-square fallback on a rank-4 covariance (plus a 1e-9 ridge) gave p = 0 exactly.
  EXPECT_EQ(WaldP(beta, BlockCov(q, G), Range(0, q), G), 1.0);
}

TEST(WaldTest, GivenEnoughBlocksWhenEffectIsLargeThenSmallP) {
  const int q = 3, G = 20;
  const Eigen::MatrixXd cov = Eigen::MatrixXd::Identity(q, q) * 1e-4;
  Eigen::VectorXd beta = Eigen::VectorXd::Constant(q, 0.1);  // t² = 300
  EXPECT_LT(WaldP(beta, cov, Range(0, q), G), 1e-6);
  Eigen::VectorXd zero = Eigen::VectorXd::Zero(q);
  EXPECT_GT(WaldP(zero, cov, Range(0, q), G), 0.99);
}

}  // namespace
}  // namespace hexsim::gap::internal
