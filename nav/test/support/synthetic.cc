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

namespace {

struct Kinematics {
  Eigen::Vector3d p, v, a;
  double yaw;
};

Kinematics FigureEightKinematics(double A, double w, double h, double swing, const Eigen::Vector3d& c, double t) {
  Kinematics k;
  const double s1 = std::sin(w * t), c1 = std::cos(w * t), s2 = std::sin(2 * w * t), c2 = std::cos(2 * w * t);
  k.p = c + Eigen::Vector3d(A * s1, 0.5 * A * s2, h * s1);
  k.v = Eigen::Vector3d(A * w * c1, A * w * c2, h * w * c1);
  k.a = Eigen::Vector3d(-A * w * w * s1, -2 * A * w * w * s2, -h * w * w * s1);
  k.yaw = swing * std::sin(0.5 * w * t) + 0.3 * w * t;  // keeps turning, so every heading is seen
  return k;
}

// Body axes of a multirotor: z along −(a − g), x towards the yaw in the plane normal to z.
Eigen::Matrix3d AttitudeFor(const Eigen::Vector3d& a_N, double yaw) {
  const Eigen::Vector3d f_N = a_N - Eigen::Vector3d(0, 0, kGravity_mps2);
  const Eigen::Vector3d z_B = -f_N.normalized();
  const Eigen::Vector3d x_c(std::cos(yaw), std::sin(yaw), 0.0);
  const Eigen::Vector3d y_B = z_B.cross(x_c).normalized();
  const Eigen::Vector3d x_B = y_B.cross(z_B);
  Eigen::Matrix3d R;
  R << x_B, y_B, z_B;
  return R;
}

}  // namespace

Trajectory FigureEight(double half_length_m, double period_s, double weave_m, double yaw_swing_rad,
                       const Eigen::Vector3d& centre_N_m) {
  const double w = 2 * kPi / period_s;
  return [=](double t) {
    const Kinematics k = FigureEightKinematics(half_length_m, w, weave_m, yaw_swing_rad, centre_N_m, t);
    Truth x;
    x.t_s = t;
    x.p_N_m = k.p;
    x.v_N_mps = k.v;
    x.a_N_mps2 = k.a;
    const Eigen::Matrix3d R = AttitudeFor(k.a, k.yaw);
    x.q_NB = Eigen::Quaterniond(R);
    // [ω]× = Rᵀ dR/dt by a central difference.
    constexpr double kH_s = 1e-4;
    const Kinematics kp = FigureEightKinematics(half_length_m, w, weave_m, yaw_swing_rad, centre_N_m, t + kH_s);
    const Kinematics km = FigureEightKinematics(half_length_m, w, weave_m, yaw_swing_rad, centre_N_m, t - kH_s);
    const Eigen::Matrix3d W = R.transpose() * (AttitudeFor(kp.a, kp.yaw) - AttitudeFor(km.a, km.yaw)) / (2 * kH_s);
    x.w_B_radps = 0.5 * Eigen::Vector3d(W(2, 1) - W(1, 2), W(0, 2) - W(2, 0), W(1, 0) - W(0, 1));
    return x;
  };
}

Eigen::Vector3d DefaultEarthField_N_uT() { return Eigen::Vector3d(26.0, -4.3, 46.0); }

Eigen::Vector3d TrueSpecificForce_B(const Truth& truth) {
  // f = Rᵀ(a − g), g = (0, 0, +g) in NED.
  return truth.q_NB.conjugate() * (truth.a_N_mps2 - Eigen::Vector3d(0, 0, kGravity_mps2));
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
      g.sample.p_N_m = x.p_N_m + cfg.gps_bias_N_m + rng->Normal3(cfg.gps_pos_std_m);
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
