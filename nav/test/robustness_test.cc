// Closed-loop-like scenarios for the estimators: manoeuvring flight with sensor biases, delayed and
// biased GPS, a biased barometer and an uncorrected compass disturbance — the conditions of the
// simulator, with a known truth.
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
  double pos_rms_m = 0, pos_max_m = 0, yaw_rms_rad = 0, yaw_max_rad = 0, tilt_max_rad = 0;
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
  EXPECT_LT(e.pos_rms_m, 1.0);
  EXPECT_LT(e.yaw_rms_rad, 2 * kDeg);
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
