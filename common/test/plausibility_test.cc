#include "hexsim/common/plausibility.h"

#include <gtest/gtest.h>

namespace hexsim::plausibility {
namespace {

TEST(PlausibilityTable, GivenEveryEntry_WhenRead_ThenItHasAUnitAReasonAndOrderedNestedRanges) {
  for (const auto& r : PlausibilityTable()) {
    EXPECT_FALSE(r.unit.empty()) << r.name;
    EXPECT_GT(r.reason.size(), 20u) << r.name;
    EXPECT_LE(r.lo, r.normal_lo) << r.name;
    EXPECT_LT(r.normal_lo, r.normal_hi) << r.name;
    EXPECT_LE(r.normal_hi, r.hi) << r.name;
  }
}

TEST(PlausibilityTable, GivenTheIssuesExamples_WhenChecked_ThenImpossibleMagnitudesAreImplausible) {
  // Fits seen on real logs before this table existed (issue 16).
  EXPECT_FALSE(IsPlausible("current_soft_iron", 1.9));
  EXPECT_FALSE(IsPlausible("current_hard_iron", 11.9));  // 119 µT/A
  EXPECT_FALSE(IsPlausible("battery_sag", -3190));
  EXPECT_FALSE(IsPlausible("thrust_scale", -1.1));
  EXPECT_FALSE(IsPlausible("latency", 0.8));
  // Real internal compasses: 3-7 mG/A.
  EXPECT_TRUE(IsPlausible("current_hard_iron", 0.6));
  EXPECT_TRUE(IsPlausible("not_in_the_table", 1e9));
  // A 111 mG residual offset is plausible but outside the normal range: recalibrate.
  EXPECT_TRUE(IsPlausible("hard_iron_offset", 11.1));
  EXPECT_FALSE(IsNormal("hard_iron_offset", 11.1));
  EXPECT_EQ(RangeText("latency"), "0..0.5 s");
}

}  // namespace
}  // namespace hexsim::plausibility
