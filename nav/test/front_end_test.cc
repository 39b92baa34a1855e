// GIVEN the same stream of good and bad samples, WHEN the ESKF and the complementary filter see it,
// THEN they admit, align and count it identically: both compose one front end (nav/src/front_end.h).
#include <cmath>
#include <limits>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "hexsim/nav/estimator.h"

namespace hexsim::nav {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kG_mps2 = 9.80665;

struct Seen {
  EstimatorStats stats;
  bool healthy_before_alignment = true, healthy_after = false;
};

Seen Feed(const std::string& name) {
  NavParams p;
  p.align_time_s = 1.0;
  p.earth.B_N_uT = Eigen::Vector3d(20.0, -3.0, 45.0);
  auto est = MakeEstimator(name, p);
  EXPECT_TRUE(est.ok()) << est.status().message();
  Estimator& e = **est;
  NavEstimate initial;
  initial.healthy = false;  // align first
  e.Reset(initial);
  Seen seen;
  const ImuSample at_rest{0.0, Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, -kG_mps2)};
  for (int k = 0; k <= 1500; ++k) {  // 1.5 s at 1 kHz, a compass sample every 10 ms
    ImuSample s = at_rest;
    s.t_s = 0.001 * k;
    e.PredictImu(s);
    if (k % 10 == 0) e.FuseMag(MagSample{s.t_s, Eigen::Vector3d(20.0, -3.0, 45.0)});
    if (k == 500) seen.healthy_before_alignment = e.Estimate().healthy;
  }
  ImuSample bad = at_rest;
  bad.t_s = 1.6;
  bad.gyro_B_radps.x() = kNaN;
  e.PredictImu(bad);                                        // non-finite: rejected
  e.PredictImu(ImuSample{1.2, at_rest.gyro_B_radps, at_rest.accel_B_mps2});  // time going back: rejected
  e.FuseMag(MagSample{1.6, Eigen::Vector3d::Zero()});       // no field: rejected
  GpsSample gps;
  gps.t_s = 1.6;
  gps.p_N_m.x() = kNaN;
  e.FuseGps(gps);                                           // rejected for position and velocity
  e.FuseBaro(BaroSample{kNaN, 0.0});                        // rejected
  seen.stats = e.Stats();
  seen.healthy_after = e.Estimate().healthy && e.Health().ok();
  return seen;
}

TEST(EstimatorFrontEnd, GivenTheSameSamplesWhenBothFiltersSeeThemThenTheyAdmitAlignAndCountAlike) {
  const Seen eskf = Feed("eskf"), comp = Feed("complementary");
  for (const Seen* s : {&eskf, &comp}) {
    EXPECT_FALSE(s->healthy_before_alignment);  // still aligning after 0.5 s of a 1 s alignment
    EXPECT_TRUE(s->healthy_after);
    EXPECT_EQ(s->stats.imu_samples, 1503);
    EXPECT_EQ(s->stats.imu_rejected_invalid, 2);
    EXPECT_EQ(s->stats.mag.rejected_invalid, 1);
    EXPECT_EQ(s->stats.gps_pos.rejected_invalid, 1);
    EXPECT_EQ(s->stats.gps_vel.rejected_invalid, 1);
    EXPECT_EQ(s->stats.baro.rejected_invalid, 1);
  }
}

}  // namespace
}  // namespace hexsim::nav
