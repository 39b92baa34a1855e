// The core's formatting (common/format.h) against fmt, which the *_io targets use: the core's
// messages must read exactly as they did when the core used fmt.
#include "hexsim/common/format.h"

#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "hexsim/common/rng.h"

namespace hexsim {
namespace {

TEST(ShortestDouble, GivenTypicalAndEdgeValuesWhenPrintedThenItMatchesFmtsDefault) {
  const double inf = std::numeric_limits<double>::infinity();
  for (double v : {0.0, -0.0, 1.0, -1.0, 0.1, 0.5, 1.5, 12.25, 2016.5, 2025.0, 100000.0, 123456789.0, 1e15, 1e16,
                   1.5e16, 1e-4, 1e-5, 0.00012345, 1.2345e-7, 5e-324, 1.7976931348623157e308, 1.0 / 3.0, -2.0 / 3.0,
                   53.0, 1e100, inf, -inf}) {
    EXPECT_EQ(ShortestDouble(v), fmt::format("{}", v)) << v;
  }
  EXPECT_EQ(ShortestDouble(std::nan("")), "nan");
}

TEST(ShortestDouble, GivenRandomDoublesAcrossMagnitudesWhenPrintedThenItMatchesFmtsDefault) {
  RngStream rng(7, "format");
  for (int i = 0; i < 2000; ++i) {
    const double mantissa = rng.Normal();  // draws in a fixed order (operands are unsequenced)
    const double v = mantissa * std::pow(10.0, -9.0 + 29.0 * rng.Uniform());
    ASSERT_EQ(ShortestDouble(v), fmt::format("{}", v)) << v;
  }
}

TEST(Format, GivenPrintfSpecsWhenFormattedThenTheyMatchFmtsEquivalents) {
  EXPECT_EQ(Format("%s:%d: %.6g uT, %.3f, %g, %+g", "a.csv", 12, 1.0 / 3.0, 2.0 / 3.0, 1e-5, 10.0),
            fmt::format("{}:{}: {:.6g} uT, {:.3f}, {:g}, {:+g}", "a.csv", 12, 1.0 / 3.0, 2.0 / 3.0, 1e-5, 10.0));
  EXPECT_EQ(Format("%s", std::string(300, 'x').c_str()), std::string(300, 'x'));
  EXPECT_EQ(Join({"none", "traditional", "adaptive"}, ", "), fmt::format("{}", fmt::join(std::vector<std::string>{"none", "traditional", "adaptive"}, ", ")));
  EXPECT_EQ(Join({}, ","), "");
}

}  // namespace
}  // namespace hexsim
