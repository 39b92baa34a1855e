#include "hexsim/common/rng.h"

#include <cmath>

#include <gtest/gtest.h>

namespace hexsim {
namespace {

TEST(RngStream, SameSeedAndNameGiveSameSequence) {
  RngStream a(42, "gyro"), b(42, "gyro");
  for (int i = 0; i < 100; ++i) EXPECT_EQ(a.NextU64(), b.NextU64());
}

TEST(RngStream, DifferentNamesAreIndependentStreams) {
  RngStream a(42, "gyro"), b(42, "accel");
  int equal = 0;
  for (int i = 0; i < 100; ++i) equal += a.NextU64() == b.NextU64();
  EXPECT_EQ(equal, 0);
}

TEST(RngStream, NormalHasUnitVarianceWithinSamplingError) {
  RngStream r(7, "normal");
  const int n = 200000;
  double sum = 0, sum2 = 0;
  for (int i = 0; i < n; ++i) {
    const double x = r.Normal();
    sum += x;
    sum2 += x * x;
  }
  const double mean = sum / n, var = sum2 / n - mean * mean;
  // Standard error of the mean is 1/sqrt(n) = 0.0022; of the variance sqrt(2/n) = 0.0032.
  EXPECT_NEAR(mean, 0.0, 5 * 0.0022);
  EXPECT_NEAR(var, 1.0, 5 * 0.0032);
}

TEST(RngStream, UniformStaysInUnitInterval) {
  RngStream r(1, "u");
  for (int i = 0; i < 10000; ++i) {
    const double u = r.Uniform();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
  }
}

}  // namespace
}  // namespace hexsim
