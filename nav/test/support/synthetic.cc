#include "support/synthetic.h"

#include <cmath>
#include <deque>

#include "hexsim/common/rotation.h"

namespace hexsim::nav::testing {

Trajectory StaticPose(double roll_rad, double pitch_rad, double yaw_rad, const Eigen::Vector3d& p_N_m) {
  const Eigen::Quaterniond q = QuatFromEuler(roll_rad, pitch_rad, yaw_rad);
  return [q, p_N_m](double t) {
    Truth x;
    x.t_s = t;
    x.p_N_m = p_N_m;
    x.q_NB = q;
    return x;
  };
}

Trajectory ConstantVelocity(const Eigen::Vector3d& v_N_mps, double yaw_rad, const Eigen::Vector3d& p0_N_m) {
  const Eigen::Quaterniond q = QuatFromEuler(0, 0, yaw_rad);
  return [=](double t) {
    Truth x;
    x.t_s = t;
    x.p_N_m = p0_N_m + v_N_mps * t;
    x.v_N_mps = v_N_mps;
    x.q_NB = q;
    return x;
  };
}

Trajectory YawSpin(double yaw_rate_radps, double yaw0_rad) {
  return [=](double t) {
    Truth x;
    x.t_s = t;
    x.q_NB = QuatFromEuler(0, 0, yaw0_rad + yaw_rate_radps * t);
    x.w_B_radps = Eigen::Vector3d(0, 0, yaw_rate_radps);
    return x;
  };
}

Eigen::Vector3d DefaultEarthField_N_uT() { return Eigen::Vector3d(26.0, -4.3, 46.0); }

Eigen::Vector3d TrueSpecificForce_B(const Truth& x) {
  // f = Rᵀ(a − g), g = (0, 0, +g) in NED.
  return x.q_NB.conjugate() * (x.a_N_mps2 - Eigen::Vector3d(0, 0, kGravity_mps2));
}

void RunScenario(Estimator* est, const Trajectory& traj, const SensorConfig& cfg, RngStream* rng,
                 double t0_s, double t1_s, const Observer& observer) {
  const double dt = 1.0 / cfg.imu_rate_hz;
  const long k0 = static_cast<long>(std::llround(t0_s * cfg.imu_rate_hz));
  const long k1 = static_cast<long>(std::llround(t1_s * cfg.imu_rate_hz));
  const long mag_every = cfg.imu_rate_hz / cfg.mag_rate_hz;
  const long baro_every = cfg.imu_rate_hz / cfg.baro_rate_hz;
  const long gps_every = cfg.imu_rate_hz / cfg.gps_rate_hz;
  const double gyro_std = cfg.gyro_noise_radps_rthz * std::sqrt(static_cast<double>(cfg.imu_rate_hz));
  const double accel_std = cfg.accel_noise_mps2_rthz * std::sqrt(static_cast<double>(cfg.imu_rate_hz));
  struct Pending {
    double arrival_s;
    GpsSample sample;
  };
  std::deque<Pending> gps_queue;
  long gps_index = k0 / gps_every;
  for (long k = k0; k <= k1; ++k) {
    const double t = k * dt;
    const Truth x = traj(t);
    ImuSample imu;
    imu.t_s = t;
    imu.gyro_B_radps = x.w_B_radps + cfg.gyro_bias_B_radps + rng->Normal3(gyro_std);
    imu.accel_B_mps2 = TrueSpecificForce_B(x) + cfg.accel_bias_B_mps2 + rng->Normal3(accel_std);
    est->PredictImu(imu);
    if (cfg.use_mag && k % mag_every == 0) {
      MagSample m;
      m.t_s = t;
      m.mag_B_uT = x.q_NB.conjugate() * cfg.B_N_uT + cfg.mag_disturbance_B_uT + rng->Normal3(cfg.mag_noise_uT);
      est->FuseMag(m);
    }
    if (cfg.use_baro && k % baro_every == 0) {
      BaroSample b;
      b.t_s = t;
      b.alt_m = -x.p_N_m.z() + cfg.baro_std_m * rng->Normal();
      est->FuseBaro(b);
    }
    if (cfg.use_gps && k % gps_every == 0) {
      Pending g;
      g.arrival_s = t + cfg.gps_delay_s;
      g.sample.t_s = cfg.gps_stamp_on_arrival ? g.arrival_s : t;
      g.sample.p_N_m = x.p_N_m + rng->Normal3(cfg.gps_pos_std_m);
      g.sample.v_N_mps = x.v_N_mps + rng->Normal3(cfg.gps_vel_std_mps);
      if (gps_index == cfg.gps_outlier_index) g.sample.p_N_m += cfg.gps_outlier_offset_N_m;
      ++gps_index;
      gps_queue.push_back(g);
    }
    while (!gps_queue.empty() && gps_queue.front().arrival_s <= t + 1e-9) {
      est->FuseGps(gps_queue.front().sample);
      gps_queue.pop_front();
    }
    if (observer) observer(x, *est);
  }
}

double CompassHeadingRad(const Eigen::Vector3d& m_B_uT, const Eigen::Quaterniond& q_NB,
                         const Eigen::Vector3d& B_N_uT) {
  const Eigen::Vector3d euler = EulerFromQuat(q_NB);
  // Level the measurement: m_L = Ry(θ)·Rx(φ)·m_B is the field in the yaw-only frame.
  const Eigen::Matrix3d R_level = (Eigen::AngleAxisd(euler.y(), Eigen::Vector3d::UnitY()) *
                                   Eigen::AngleAxisd(euler.x(), Eigen::Vector3d::UnitX()))
                                      .toRotationMatrix();
  const Eigen::Vector3d m_L = R_level * m_B_uT;
  // In the yaw-only frame the horizontal field points at −ψ_mag from the nose.
  const double psi_mag = std::atan2(-m_L.y(), m_L.x());
  return WrapPi(psi_mag + std::atan2(B_N_uT.y(), B_N_uT.x()));
}

NavParams ParamsFor(const SensorConfig& cfg) {
  NavParams p;
  p.gyro_noise_radps_rthz = cfg.gyro_noise_radps_rthz;
  p.accel_noise_mps2_rthz = cfg.accel_noise_mps2_rthz;
  p.earth.B_N_uT = cfg.B_N_uT;
  return p;
}

NavEstimate InitialFrom(const Trajectory& traj, double yaw_error_rad) {
  const Truth x = traj(0.0);
  NavEstimate e;
  e.p_N_m = x.p_N_m;
  e.v_N_mps = x.v_N_mps;
  e.q_NB = QuatExp(Eigen::Vector3d(0, 0, yaw_error_rad)) * x.q_NB;
  e.healthy = true;
  return e;
}

}  // namespace hexsim::nav::testing
