// The in-flight model's disturbance term as autopilot parameters (autopilot_params.h
// CompensationParams): what happens to the log's own COMPASS_MOTCT / COMPASS_MOT*.
#include <cmath>

#include <gtest/gtest.h>

#include "hexsim/magnetics/autopilot_params.h"

namespace hexsim::magnetics {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

double Value(const ParamList& p, const std::string& name) {
  for (const auto& [n, v] : p) {
    if (n == name) return v;
  }
  return std::nan("");
}

const Vector3d kD(0.1, 0.6, -0.2);       // µT/A: 6.4 mG/A
const Vector3d kHalf(0.05, 0.05, 0.05);  // its interval half-widths

TEST(CompensationParams, GivenAResolvedCurrentFieldAndAThrottleCompensationInTheLog_ThenItIsReplacedAndTheCommentSaysSo) {
  const MotorCompensationInLog log{1, Vector3d(3.0, -5.0, 1.0)};
  const MotorParams m = CompensationParams(1, -1, true, true, false, kD, kHalf, Matrix3d::Identity(), log, -1, Vector3d::Zero());
  EXPECT_EQ(m.action, "replaced");
  EXPECT_EQ(Value(m.ardupilot, "COMPASS_MOTCT"), 2.0);
  EXPECT_NEAR(Value(m.ardupilot, "COMPASS_MOT2_Y"), -6.0, 1e-12);  // MOT = −d in mG/A
  EXPECT_NE(m.comment.find("the log had COMPASS_MOTCT 1"), std::string::npos) << m.comment;
  EXPECT_NE(ArduPilotParmText(m.ardupilot, "hexsim gap diagnose", {m.comment}).find("# COMPASS_MOTCT/COMPASS_MOT2_*: replaced"),
            std::string::npos);
}

TEST(CompensationParams, GivenAThrottleFit_ThenMotct1AndPx4ThrottleCompensation) {
  const MotorParams m = CompensationParams(0, 0, true, true, true, Vector3d(2, -6, 4), kHalf, Matrix3d::Identity(), {}, 0,
                                           Vector3d::Zero());
  EXPECT_EQ(m.action, "written");
  EXPECT_EQ(Value(m.ardupilot, "COMPASS_MOTCT"), 1.0);
  EXPECT_NEAR(Value(m.ardupilot, "COMPASS_MOT_Z"), -40.0, 1e-12);
  EXPECT_EQ(Value(m.px4, "CAL_MAG_COMP_TYP"), 1.0);
  EXPECT_NEAR(Value(m.px4, "CAL_MAG0_ZCOMP"), -0.04, 1e-12);  // gauss at full throttle
}

TEST(CompensationParams, GivenAnUnresolvedFit_ThenTheLogsCompensationIsKeptOrZeroedByItsInterval) {
  const Vector3d d(0.01, -0.02, 0.0);  // zero within ±0.05
  // The log's −MOT/10 inside the interval: kept.
  MotorParams m = CompensationParams(0, -1, true, false, false, d, kHalf, Matrix3d::Identity(), {2, Vector3d(0.0, 0.5, 0.0)},
                                     -1, Vector3d::Zero());
  EXPECT_EQ(m.action, "kept");
  EXPECT_EQ(Value(m.ardupilot, "COMPASS_MOT_Y"), 0.5);
  // Far outside it, zero inside: zeroed.
  m = CompensationParams(0, -1, true, false, false, d, kHalf, Matrix3d::Identity(), {2, Vector3d(0.0, 8.0, 0.0)}, -1,
                         Vector3d::Zero());
  EXPECT_EQ(m.action, "zeroed");
  EXPECT_EQ(Value(m.ardupilot, "COMPASS_MOT_Y"), 0.0);
  EXPECT_EQ(Value(m.ardupilot, "COMPASS_MOTCT"), 2.0);
  // No compensation in the log, nothing resolved: no parameter line.
  m = CompensationParams(0, -1, true, false, false, d, kHalf, Matrix3d::Identity(), {0, Vector3d::Zero()}, -1, Vector3d::Zero());
  EXPECT_EQ(m.action, "none");
  EXPECT_TRUE(m.ardupilot.empty());
}

// A public ArduCopter 4.7.0-dev log ran its motors on the ground only (props off): its throttle fit
// replaced the log's current compensation (COMPASS_MOTCT 2). A fit that saw no flight keeps the log's.
TEST(CompensationParams, GivenAFitThatSawNoFlight_ThenTheLogsCompensationIsKeptAndTheCommentSaysWhy) {
  const MotorCompensationInLog log{2, Vector3d(1.1, 0.6, 2.7)};
  const std::string why = "on runs on the ground only";
  const MotorParams m = CompensationParams(0, -1, true, true, true, Vector3d(2, -6, 4), kHalf, Matrix3d::Identity(), log,
                                           -1, Vector3d::Zero(), why);
  EXPECT_EQ(m.action, "kept");
  EXPECT_EQ(Value(m.ardupilot, "COMPASS_MOTCT"), 2.0);
  EXPECT_NEAR(Value(m.ardupilot, "COMPASS_MOT_Z"), 2.7, 1e-12);
  EXPECT_NE(m.comment.find("saw no flight, on runs on the ground only"), std::string::npos) << m.comment;
  // nothing in the log, and a fit whose zero-including interval would zero it: neither written nor zeroed
  EXPECT_EQ(CompensationParams(0, -1, true, true, true, Vector3d(2, -6, 4), kHalf, Matrix3d::Identity(), {0, Vector3d::Zero()},
                               -1, Vector3d::Zero(), why).action,
            "none");
  EXPECT_EQ(CompensationParams(0, -1, true, false, false, Vector3d(0.01, 0, 0), kHalf, Matrix3d::Identity(),
                               {2, Vector3d(0.0, 8.0, 0.0)}, -1, Vector3d::Zero(), why).action,
            "kept");
}

}  // namespace
}  // namespace hexsim::magnetics
