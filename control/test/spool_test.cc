#include "hexsim/control/spool.h"

#include <gtest/gtest.h>

namespace hexsim::control {
namespace {

constexpr double kDt_s = 0.0025;  // a 400 Hz autopilot

TEST(Spool, GivenRunFromShutDownWhenSteppedThenGroundIdleLastsTheSpoolTimeAndTheCapRampsAtOnePerSpoolTime) {
  Spool spool(0.5);
  EXPECT_FALSE(spool.spinning());
  double t = 0.0;
  while (spool.state() != SpoolState::kSpoolingUp) {
    spool.Step(true, 0.4, kDt_s);
    t += kDt_s;
    ASSERT_LT(t, 2.0);
    if (spool.state() == SpoolState::kGroundIdle) {
      EXPECT_FALSE(spool.mixing());
    }
  }
  EXPECT_NEAR(t, 0.5 + kDt_s, 1.5 * kDt_s);  // one tick to leave shut-down, then 0.5 s of idle
  const double t_up = t;
  while (spool.state() == SpoolState::kSpoolingUp) {
    EXPECT_LT(spool.collective_cap(), 0.4 + 1e-12);
    spool.Step(true, 0.4, kDt_s);
    t += kDt_s;
  }
  EXPECT_EQ(spool.state(), SpoolState::kThrottleUnlimited);
  EXPECT_NEAR(t - t_up, 0.4 * 0.5, 2.0 * kDt_s);  // the cap reaches 0.4 after 0.4 spool times
  EXPECT_EQ(spool.collective_cap(), 1.0);
}

TEST(Spool, GivenUnlimitedWhenStoppedThenTheCapFallsFromTheCollectiveThenIdleThenShutDown) {
  Spool spool(0.5);
  for (int k = 0; k < 1000 && spool.state() != SpoolState::kThrottleUnlimited; ++k) spool.Step(true, 0.0, kDt_s);
  ASSERT_EQ(spool.state(), SpoolState::kThrottleUnlimited);
  spool.Step(false, 0.3, kDt_s);
  EXPECT_EQ(spool.state(), SpoolState::kSpoolingDown);
  EXPECT_NEAR(spool.collective_cap(), 0.3, 1e-12);
  double t = 0.0;
  while (spool.spinning()) {
    spool.Step(false, 0.0, kDt_s);
    t += kDt_s;
    ASSERT_LT(t, 3.0);
  }
  EXPECT_NEAR(t, 0.3 * 0.5 + 0.5, 3.0 * kDt_s);  // cap 0.3 -> 0, then idle 1 -> 0
}

TEST(Spool, GivenZeroSpoolTimeWhenRunThenEveryTransitionIsImmediate) {
  Spool spool(0.0);
  spool.Step(true, 0.5, kDt_s);  // shut down -> ground idle
  spool.Step(true, 0.5, kDt_s);  // -> spooling up
  spool.Step(true, 0.5, kDt_s);  // -> unlimited
  EXPECT_EQ(spool.state(), SpoolState::kThrottleUnlimited);
}

}  // namespace
}  // namespace hexsim::control
