// The cluster-robust Wald test of gap's attribution: F with G − q degrees of freedom, and "not
// testable" (p = 1) where the parameters outnumber the blocks.
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "../src/attribution.h"
#include "../src/nuisance.h"
#include "../src/verdict.h"

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

// A nuisance term is judged by the wider of its sandwich and jackknife spreads. Measured on a public
// PX4 log's 1 Hz internal compass: offset 35.6 uT, sandwich spread small enough that the offset's
// lower bound stood beyond the normal 5 uT, while the jackknife's printed interval was [0, 77.9] uT,
// and the verdict named an offset "outside its normal range" printed with an interval reaching 0.
TEST(GapNuisanceJudgement, GivenAJackknifeWiderThanTheSandwich_ThenTheTermIsJudgedByTheWiderInterval) {
  const double t975 = 2.26;  // Student-t at 9 degrees of freedom (10 blocks)
  const Interval narrow = JudgedInterval(35.6, 5.0, 1.0, t975);
  EXPECT_NEAR(narrow.lo, 35.6 - t975 * 5.0, 1e-12);
  const Interval wide = JudgedInterval(35.6, 5.0, 17.2, t975);
  EXPECT_LT(wide.lo, 5.0);  // not beyond the normal 5 uT: not a finding
  EXPECT_NEAR(wide.hi, 35.6 + t975 * 17.2, 1e-12);
  EXPECT_GT(JudgedInterval(35.6, 5.0, 4.0, t975).lo, 5.0);  // both narrow: beyond it
}

// A public PX4 log (compass at 2 Hz, a 27-s flight without rotation) fitted a 124.8 uT offset
// [78.2, 171.4]: the verdict named it "hard_iron_offset 1247.9 mG (a nuisance term outside its normal
// range)" although it lies outside the offset's physical range 0..85 uT.
TEST(GapNuisanceJudgement, GivenAnOffsetOutsideItsPhysicalRange_ThenItIsAModelMismatchNotTheVerdict) {
  EXPECT_EQ(ReadOffset(124.8, Interval{78.2, 171.4}), OffsetReading::kImplausible);
  EXPECT_EQ(ReadOffset(13.7, Interval{8.7, 18.3}), OffsetReading::kBeyondNormal);
  EXPECT_EQ(ReadOffset(13.7, Interval{3.0, 24.0}), OffsetReading::kNormal);
}

}  // namespace
}  // namespace hexsim::gap::internal
