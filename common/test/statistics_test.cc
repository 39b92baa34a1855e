#include "hexsim/common/statistics.h"

#include <cmath>

#include <gtest/gtest.h>

#include "hexsim/common/rng.h"

namespace hexsim {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(StudentTQuantile, GivenSmallDegreesOfFreedomWhenTheTwoSided95QuantileIsAskedThenItMatchesTheTables) {
  // Standard tables (4 decimals).
  const std::pair<double, double> table[] = {{1, 12.7062}, {2, 4.3027}, {3, 3.1824}, {4, 2.7764}, {5, 2.5706},
                                             {10, 2.2281}, {30, 2.0423}, {40, 2.0211}, {100, 1.9840}};
  for (const auto& [dof, t] : table) EXPECT_NEAR(StudentT975(dof), t, 6e-5) << dof;
  EXPECT_NEAR(StudentTQuantile(0.995, 1), 63.6567, 1e-4);
  EXPECT_NEAR(StudentTQuantile(0.995, 5), 4.0321, 1e-4);
  EXPECT_NEAR(StudentTQuantile(0.95, 1), 6.3138, 1e-4);
}

TEST(StudentTQuantile, GivenOneAndTwoDegreesOfFreedomThenItEqualsTheClosedForms) {
  for (double p : {0.6, 0.9, 0.975, 0.999, 0.025, 0.3}) {
    EXPECT_NEAR(StudentTQuantile(p, 1), std::tan(kPi * (p - 0.5)), 1e-10 * (1 + std::fabs(std::tan(kPi * (p - 0.5)))));
    const double t2 = (2 * p - 1) / std::sqrt(2 * p * (1 - p));  // Cauchy and ν = 2 closed forms
    EXPECT_NEAR(StudentTQuantile(p, 2), t2, 1e-10 * (1 + std::fabs(t2)));
  }
}

TEST(StudentTQuantile, GivenManyDegreesOfFreedomThenItTendsToTheNormalQuantile) {
  EXPECT_NEAR(StudentT975(1e6), 1.959963984540054, 1e-5);
  EXPECT_DOUBLE_EQ(StudentTQuantile(0.5, 7), 0.0);
  EXPECT_TRUE(std::isnan(StudentT975(0)));
  EXPECT_TRUE(std::isnan(StudentTQuantile(1.0, 3)));
}

TEST(StudentTCdf, GivenAQuantileWhenTheCdfIsEvaluatedThenTheProbabilityComesBack) {
  for (double dof : {0.5, 1.0, 2.5, 7.0, 60.0, 5000.0}) {
    for (double p : {0.001, 0.2, 0.5, 0.8, 0.975, 0.9999}) {
      EXPECT_NEAR(StudentTCdf(StudentTQuantile(p, dof), dof), p, 1e-12) << dof << " " << p;
    }
  }
}

TEST(RegularizedIncompleteBeta, GivenAOrBEqualToOneThenItEqualsThePowerLaws) {
  for (double x : {0.0, 0.01, 0.3, 0.77, 1.0}) {
    EXPECT_NEAR(RegularizedIncompleteBeta(2.5, 1.0, x), std::pow(x, 2.5), 1e-13);     // I_x(a, 1) = x^a
    EXPECT_NEAR(RegularizedIncompleteBeta(1.0, 3.5, x), 1 - std::pow(1 - x, 3.5), 1e-13);  // 1 − (1 − x)^b
    const double p = RegularizedIncompleteBeta(0.5, 4.0, x);
    if (x > 0 && x < 1) {
      EXPECT_NEAR(InverseRegularizedIncompleteBeta(0.5, 4.0, p), x, 1e-12 * (1 + x));
    }
  }
  EXPECT_TRUE(std::isnan(RegularizedIncompleteBeta(-1.0, 1.0, 0.5)));
}

TEST(Summarize, GivenNormalSamplesOfFiveWhenTheIntervalIsComputedThenItCoversTheTrueMeanAbout95PercentOfTheTime) {
  RngStream rng(3, "ci_coverage");
  constexpr int kTrials = 4000;
  constexpr double kMean = 5.0, kStd = 2.0;
  int covered = 0;
  for (int t = 0; t < kTrials; ++t) {
    std::vector<double> v(5);
    for (double& x : v) x = rng.Normal(kMean, kStd);
    const SampleStats s = Summarize(v);
    ASSERT_TRUE(s.ci95_lo && s.ci95_hi && s.std);
    covered += (*s.ci95_lo <= kMean && kMean <= *s.ci95_hi);
  }
  // Binomial(4000, 0.95): std 0.0034; 4 sigma.
  EXPECT_NEAR(static_cast<double>(covered) / kTrials, 0.95, 0.014);
}

TEST(Summarize, GivenOneOrNoValueThenThereIsNoSpreadOrInterval) {
  EXPECT_EQ(Summarize({}).n, 0u);
  const SampleStats one = Summarize({3.0});
  EXPECT_DOUBLE_EQ(one.mean, 3.0);
  EXPECT_FALSE(one.std.has_value());
  EXPECT_FALSE(one.ci95_lo.has_value());
  const SampleStats two = Summarize({1.0, 3.0});
  EXPECT_DOUBLE_EQ(two.mean, 2.0);
  EXPECT_DOUBLE_EQ(*two.std, std::sqrt(2.0));
  EXPECT_NEAR(*two.ci95_hi - 2.0, 12.7062 * std::sqrt(2.0) / std::sqrt(2.0), 1e-4);
  EXPECT_TRUE(std::isnan(Mean({})));
  EXPECT_TRUE(std::isnan(SampleStd({1.0})));
}

}  // namespace
}  // namespace hexsim

namespace hexsim {
namespace {

TEST(SummarizeNonNegative, GivenSkewedNonNegativeSamplesWhenTheTIntervalCrossesZeroThenItIsClippedAndSaysSo) {
  // Given: 0.1, 0.2, 3.0: the t interval (n = 3, t = 4.303) reaches far below zero
  const std::vector<double> x = {0.1, 0.2, 3.0};
  // When
  const SampleStats plain = Summarize(x), clipped = SummarizeNonNegative(x);
  // Then
  ASSERT_TRUE(plain.ci95_lo && clipped.ci95_lo);
  EXPECT_LT(*plain.ci95_lo, 0.0);
  EXPECT_EQ(*clipped.ci95_lo, 0.0);
  EXPECT_TRUE(clipped.ci95_clipped);
  EXPECT_DOUBLE_EQ(*clipped.ci95_hi, *plain.ci95_hi);
  EXPECT_DOUBLE_EQ(clipped.mean, plain.mean);
  // ... and an interval above zero is left alone.
  const SampleStats tight = SummarizeNonNegative({2.0, 2.1, 2.2});
  EXPECT_FALSE(tight.ci95_clipped);
  EXPECT_GT(*tight.ci95_lo, 0.0);
}

}  // namespace
}  // namespace hexsim
