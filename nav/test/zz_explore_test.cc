#include <cstdlib>
#include <cstdio>
#include <gtest/gtest.h>
#include "hexsim/common/rng.h"
#include "hexsim/common/rotation.h"
#include "hexsim/nav/estimator.h"
#include "support/synthetic.h"
namespace hexsim::nav {
namespace {
using namespace testing;
TEST(Explore, Run) {
  const char* env = std::getenv("EXPLORE");
  if (!env) GTEST_SKIP();
  int mode = std::atoi(env);
  SensorConfig cfg;
  cfg.imu_rate_hz = 400; cfg.mag_rate_hz = 50; cfg.gps_rate_hz = 5; cfg.baro_rate_hz = 50;
  cfg.gps_pos_std_m = 0.3; cfg.gps_vel_std_mps = 0.1; cfg.gps_delay_s = (mode & 1) ? 0.0 : 0.2;
  cfg.mag_noise_uT = 0.2; cfg.baro_std_m = 0.3; cfg.gyro_noise_radps_rthz = 1e-4;
  cfg.use_mag = !(mode & 2);
  cfg.use_baro = !(mode & 4);
  double A = (mode & 8) ? 5.0 : 25.0;
  double swing = (mode & 16) ? 0.0 : 40 * kDegToRad;
  const auto traj = FigureEight(A, 30.0, (mode & 32) ? 0.0 : 2.0, swing);
  NavParams p = ParamsFor(cfg);
  auto est = MakeEstimator(std::getenv("EST") ? std::getenv("EST") : "eskf", p).value();
  est->Reset(InitialFrom(traj, 0.0));
  RngStream rng(5, "fly");
  RunScenario(est.get(), traj, cfg, &rng, 0.0, 60.0, [&](const Truth& x, const Estimator& es) {
    if (std::fmod(x.t_s, 3.0) > 1e-6) return;
    const NavEstimate ne = es.Estimate();
    Eigen::Vector3d e = EulerFromQuat(ne.q_NB) - EulerFromQuat(x.q_NB);
    for (int i = 0; i < 3; ++i) e(i) = WrapPi(e(i)) / kDegToRad;
    std::printf("t %5.1f dp %7.2f %7.2f %7.2f dv %6.2f %6.2f %6.2f deul %6.2f %6.2f %6.2f bg %7.4f %7.4f %7.4f ba %6.3f %6.3f %6.3f\n", x.t_s,
                ne.p_N_m.x() - x.p_N_m.x(), ne.p_N_m.y() - x.p_N_m.y(), ne.p_N_m.z() - x.p_N_m.z(),
                ne.v_N_mps.x() - x.v_N_mps.x(), ne.v_N_mps.y() - x.v_N_mps.y(), ne.v_N_mps.z() - x.v_N_mps.z(), e.x(), e.y(), e.z(),
                ne.gyro_bias_B_radps.x(), ne.gyro_bias_B_radps.y(), ne.gyro_bias_B_radps.z(), ne.accel_bias_B_mps2.x(), ne.accel_bias_B_mps2.y(), ne.accel_bias_B_mps2.z());
  });
  auto st = est->Stats();
  std::printf("gps fused %ld rej %ld vel fused %ld rej %ld mag %ld/%ld baro %ld/%ld\n", (long)st.gps_pos.fused, (long)st.gps_pos.rejected_gate, (long)st.gps_vel.fused, (long)st.gps_vel.rejected_gate, (long)st.mag.fused, (long)st.mag.rejected_gate, (long)st.baro.fused, (long)st.baro.rejected_gate);
}
}  // namespace
}  // namespace hexsim::nav
