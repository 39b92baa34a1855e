// Closed-loop-like scenarios for the estimators: manoeuvring flight with sensor biases, delayed and
// biased GPS, a biased barometer and an uncorrected compass disturbance — the conditions of the
// simulator, with a known truth.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "hexsim/common/rng.h"
#include "hexsim/common/rotation.h"
#include "hexsim/nav/estimator.h"
#include "support/synthetic.h"

namespace hexsim::nav {
namespace {

using testing::FigureEight;
using testing::InitialFrom;
using testing::ParamsFor;
using testing::RunScenario;
using testing::SensorConfig;
using testing::Truth;

constexpr double kDeg = kDegToRad;

std::unique_ptr<Estimator> Make(const std::string& name, const NavParams& p) {
  auto r = MakeEstimator(name, p);
  EXPECT_TRUE(r.ok()) << r.status().message();
  return std::move(r).value();
}

struct Errors {
  double pos_rms_m = 0, pos_max_m = 0, yaw_rms_rad = 0, yaw_max_rad = 0, tilt_max_rad = 0, horiz_end_m = 0;
};

Errors Fly(const std::string& name, const SensorConfig& cfg, const NavParams& p, double duration_s, uint64_t seed) {
  const auto traj = FigureEight(25.0, 30.0, 2.0, 40 * kDeg);
  auto est = Make(name, p);
  est->Reset(InitialFrom(traj, 0.0));
  RngStream rng(seed, "fly");
  double sp = 0, sy = 0;
  long n = 0;
  Errors e;
  RunScenario(est.get(), traj, cfg, &rng, 0.0, duration_s, [&](const Truth& x, const Estimator& es) {
    const NavEstimate ne = es.Estimate();
    const double ep = (ne.p_N_m - x.p_N_m).norm();
    const double ey = WrapPi(EulerFromQuat(ne.q_NB).z() - EulerFromQuat(x.q_NB).z());
    const Eigen::Vector3d d_est = ne.q_NB * Eigen::Vector3d::UnitZ(), d_true = x.q_NB * Eigen::Vector3d::UnitZ();
    const double tilt = std::acos(std::clamp(d_est.dot(d_true), -1.0, 1.0));
    if (x.t_s > 5.0) {
      sp += ep * ep;
      sy += ey * ey;
      ++n;
      e.pos_max_m = std::max(e.pos_max_m, ep);
      e.yaw_max_rad = std::max(e.yaw_max_rad, std::abs(ey));
      e.tilt_max_rad = std::max(e.tilt_max_rad, tilt);
    }
  });
  e.pos_rms_m = std::sqrt(sp / n);
  e.yaw_rms_rad = std::sqrt(sy / n);
  EXPECT_TRUE(est->Health().ok()) << est->Health().message();
  const EstimatorStats st = est->Stats();
  const Truth x_end = traj(duration_s);
  e.horiz_end_m = (est->Estimate().p_N_m - x_end.p_N_m).head<2>().norm();
  std::printf("%s: pos rms %.2f max %.2f m, yaw rms %.2f max %.2f deg, tilt max %.2f deg; gps fused %ld rejected %ld, mag fused %ld rejected %ld\n",
              name.c_str(), e.pos_rms_m, e.pos_max_m, e.yaw_rms_rad / kDeg, e.yaw_max_rad / kDeg, e.tilt_max_rad / kDeg,
              static_cast<long>(st.gps_pos.fused), static_cast<long>(st.gps_pos.rejected_gate),
              static_cast<long>(st.mag.fused), static_cast<long>(st.mag.rejected_gate));
  return e;
}

class EveryEstimatorInFlight : public ::testing::TestWithParam<std::string> {};

TEST_P(EveryEstimatorInFlight, GivenManoeuvringFlightWithIdealSensors_WhenTracked_ThenPositionAndYawStayTight) {
  SensorConfig cfg;
  cfg.imu_rate_hz = 400;
  cfg.mag_rate_hz = 50;  // 400/75 is not an integer
  cfg.gps_rate_hz = 5;
  cfg.baro_rate_hz = 50;
  cfg.gps_pos_std_m = 0.3;
  cfg.gps_vel_std_mps = 0.1;
  cfg.gps_delay_s = 0.2;
  cfg.mag_noise_uT = 0.2;
  cfg.baro_std_m = 0.3;
  cfg.gyro_noise_radps_rthz = 1e-4;
  const Errors e = Fly(GetParam(), cfg, ParamsFor(cfg), 60.0, 5);
  // GPS noise 0.3 m, averaged: well under 1 m. Yaw: the compass gives 0.2/26 µT ≈ 0.4° per sample.
  // The ESKF (before its heading Jacobian took the tilt leak through the vertical field) ran away by
  // hundreds of metres here. The complementary filter's tilt reference is the GPS acceleration,
  // 0.2 s late and low-passed: its tilt lags in the turns by up to ~3°, ×tan(63°) in the heading.
  EXPECT_LT(e.pos_rms_m, 1.0);
  EXPECT_LT(e.yaw_rms_rad, (GetParam() == "eskf" ? 1.5 : 4.0) * kDeg);
  EXPECT_LT(e.tilt_max_rad, (GetParam() == "eskf" ? 2.0 : 5.0) * kDeg);
}

TEST_P(EveryEstimatorInFlight, GivenGpsHeight5mOffTheBarometer_WhenManoeuvring_ThenHorizontalGpsIsStillFused) {
  SensorConfig cfg;
  cfg.imu_rate_hz = 400;
  cfg.mag_rate_hz = 50;
  cfg.gps_rate_hz = 5;
  cfg.baro_rate_hz = 50;
  cfg.gps_pos_std_m = 0.3;
  cfg.gps_vel_std_mps = 0.1;
  cfg.mag_noise_uT = 0.2;
  cfg.baro_std_m = 0.3;
  cfg.gps_bias_N_m = Eigen::Vector3d(0, 0, 5.0);  // a GPS height bias, as real receivers have
  const Errors e = Fly(GetParam(), cfg, ParamsFor(cfg), 40.0, 6);
  // The estimate's height sits between baro and GPS (≤ 5 m off); the horizontal must stay tight —
  // a vertical GPS/baro disagreement used to reject the whole GPS position and let it run away.
  EXPECT_LT(e.pos_max_m, 5.5);
  EXPECT_LT(e.horiz_end_m, 1.0);
  EXPECT_LT(e.yaw_rms_rad, 4.0 * kDeg);
}

INSTANTIATE_TEST_SUITE_P(Nav, EveryEstimatorInFlight, ::testing::Values("eskf", "complementary"));

}  // namespace
}  // namespace hexsim::nav

namespace hexsim::nav {
namespace {

// The test support itself: a perfect IMU on the figure-eight truth, integrated, must reproduce it.
TEST(FigureEightSupport, GivenPerfectImuOnTheTruth_WhenStrapdownIntegratedFor30s_ThenPathAndAttitudeAreReproduced) {
  const auto traj = testing::FigureEight(25.0, 30.0, 2.0, 40 * kDeg);
  const double dt = 1.0 / 2000.0;
  Truth x0 = traj(0.0);
  Eigen::Quaterniond q = x0.q_NB;
  Eigen::Vector3d v = x0.v_N_mps, p = x0.p_N_m;
  for (int k = 1; k <= 60000; ++k) {
    const Truth a = traj((k - 1) * dt), b = traj(k * dt);
    const Eigen::Vector3d w = 0.5 * (a.w_B_radps + b.w_B_radps);
    const Eigen::Vector3d f_N = 0.5 * (a.q_NB * testing::TrueSpecificForce_B(a) + b.q_NB * testing::TrueSpecificForce_B(b));
    const Eigen::Vector3d acc = f_N + Eigen::Vector3d(0, 0, kGravity_mps2);
    p += v * dt + 0.5 * acc * dt * dt;
    v += acc * dt;
    q = (q * QuatExp(w * dt)).normalized();
  }
  const Truth x1 = traj(30.0);
  EXPECT_LT((p - x1.p_N_m).norm(), 0.05);
  EXPECT_LT((v - x1.v_N_mps).norm(), 0.01);
  EXPECT_LT(QuatLog(q.conjugate() * x1.q_NB).norm(), 0.01 * kDeg);
}

}  // namespace
}  // namespace hexsim::nav

namespace hexsim::nav {
namespace {

// EKF2-style recovery. Each scenario starts the filter confidently wrong, so the sensor is gated
// out; before the recovery logic it stayed gated out for ever.
TEST(EskfRecovery, GivenPositionConfidently30mOff_WhenGpsIsGatedOut_ThenPositionResetsToGpsAfterTheTimeout) {
  SensorConfig cfg;
  cfg.gps_pos_std_m = 0.3;
  cfg.gps_vel_std_mps = 0.05;
  const auto traj = testing::ConstantVelocity(Eigen::Vector3d(3, 0, 0), 0.0, Eigen::Vector3d(0, 0, -10));
  NavParams p = ParamsFor(cfg);
  p.init_pos_std_m = 0.1;
  p.init_vel_std_mps = 0.05;
  auto est = MakeEstimator("eskf", p).value();
  NavEstimate init = InitialFrom(traj, 0.0);
  init.p_N_m += Eigen::Vector3d(30, -10, 0);
  est->Reset(init);
  RngStream rng(31, "gps_reset");
  double err_before = 0;
  RunScenario(est.get(), traj, cfg, &rng, 0.0, 0.8 * p.gps_reset_timeout_s, [&](const Truth& x, const Estimator& e) {
    err_before = (e.Estimate().p_N_m - x.p_N_m).head<2>().norm();
  });
  EXPECT_GT(err_before, 25.0);  // gated: GPS alone cannot pull it back
  EXPECT_EQ(est->Stats().gps_pos.resets, 0);
  double err_after = 0;
  RunScenario(est.get(), traj, cfg, &rng, 0.8 * p.gps_reset_timeout_s + 0.001, p.gps_reset_timeout_s + 2.0,
              [&](const Truth& x, const Estimator& e) { err_after = (e.Estimate().p_N_m - x.p_N_m).head<2>().norm(); });
  EXPECT_EQ(est->Stats().gps_pos.resets, 1);
  EXPECT_LT(err_after, 1.0);  // a few GPS noise std
  EXPECT_TRUE(est->Health().ok());
}

TEST(EskfRecovery, GivenYawConfidently60DegOff_WhenTheCompassIsGatedOut_ThenYawResetsToTheCompassAfterTheTimeout) {
  SensorConfig cfg;
  cfg.gps_pos_std_m = 0.3;
  cfg.mag_noise_uT = 0.2;
  const auto traj = testing::StaticPose(0, 0, 20 * kDeg, Eigen::Vector3d(0, 0, -10));
  NavParams p = ParamsFor(cfg);
  p.init_yaw_std_rad = 0.01;
  p.init_accel_bias_std_mps2 = 0.05;
  auto est = MakeEstimator("eskf", p).value();
  est->Reset(InitialFrom(traj, 60 * kDeg));
  RngStream rng(32, "yaw_reset");
  double err = 0;
  RunScenario(est.get(), traj, cfg, &rng, 0.0, 0.8 * p.mag_yaw_reset_timeout_s, [&](const Truth& x, const Estimator& e) {
    err = WrapPi(EulerFromQuat(e.Estimate().q_NB).z() - EulerFromQuat(x.q_NB).z());
  });
  EXPECT_GT(std::abs(err), 50 * kDeg);
  EXPECT_EQ(est->Stats().mag.resets, 0);
  RunScenario(est.get(), traj, cfg, &rng, 0.8 * p.mag_yaw_reset_timeout_s + 0.001, p.mag_yaw_reset_timeout_s + 5.0,
              [&](const Truth& x, const Estimator& e) {
                err = WrapPi(EulerFromQuat(e.Estimate().q_NB).z() - EulerFromQuat(x.q_NB).z());
              });
  EXPECT_EQ(est->Stats().mag.resets, 1);
  EXPECT_LT(std::abs(err), 1.0 * kDeg);  // 0.2 µT on a 26 µT horizontal field: ~0.4° per sample
}

}  // namespace
}  // namespace hexsim::nav
