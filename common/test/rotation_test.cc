#include "hexsim/common/rotation.h"

#include <gtest/gtest.h>

namespace hexsim {
namespace {

TEST(Rotation, EulerRoundTrip) {
  for (double roll : {-1.0, -0.3, 0.0, 0.7}) {
    for (double pitch : {-1.2, 0.0, 0.4}) {
      for (double yaw : {-3.0, -1.0, 0.0, 2.5, 3.1}) {
        const Eigen::Vector3d e = EulerFromQuat(QuatFromEuler(roll, pitch, yaw));
        EXPECT_NEAR(e.x(), roll, 1e-12);
        EXPECT_NEAR(e.y(), pitch, 1e-12);
        EXPECT_NEAR(e.z(), yaw, 1e-12);
      }
    }
  }
}

TEST(Rotation, YawNinetyDegreesPointsBodyForwardEast) {
  const Eigen::Quaterniond q = QuatFromEuler(0, 0, kPi / 2);
  const Eigen::Vector3d fwd_N = q * Eigen::Vector3d::UnitX();
  EXPECT_NEAR(fwd_N.y(), 1.0, 1e-12);
  EXPECT_NEAR(YawDeg(q), 90.0, 1e-9);
}

TEST(Rotation, WrapKeepsHalfOpenInterval) {
  EXPECT_DOUBLE_EQ(WrapDeg180(180.0), 180.0);
  EXPECT_DOUBLE_EQ(WrapDeg180(-180.0), 180.0);
  EXPECT_NEAR(WrapDeg180(370.0), 10.0, 1e-12);
  EXPECT_NEAR(WrapPi(-kPi - 0.1), kPi - 0.1, 1e-12);
}

TEST(Rotation, ExpLogRoundTrip) {
  const Eigen::Vector3d r(0.3, -0.2, 1.1);
  EXPECT_TRUE(QuatLog(QuatExp(r)).isApprox(r, 1e-12));
  EXPECT_TRUE((Skew(r) * Eigen::Vector3d(1, 2, 3)).isApprox(r.cross(Eigen::Vector3d(1, 2, 3))));
}

}  // namespace
}  // namespace hexsim
