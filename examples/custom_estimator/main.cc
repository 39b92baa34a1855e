// A custom navigation estimator plugged into hexsim through nav::Estimator, built outside the hexsim
// tree against the installed package: the built-in cascade flies the square mission on its output.
//
// Attitude: a Mahony filter, q̇ = ½ q ⊗ (ω_gyro − b + kp·e), e = â × v̂ with â the measured and
// v̂ = Rᵀ(a_N − g·e3)/|…| the predicted specific-force direction (NED: at rest the accelerometer
// reads −g along down). A multirotor's accelerometer sees thrust, not gravity, while it accelerates,
// so a_N comes from the GPS velocity (differenced, low-passed): without it the filter believes the
// vehicle is level whenever it accelerates. Plus a heading correction kψ·(ψ_mag − ψ)·Rᵀe3 from the tilt-compensated compass
// heading, and a gyro-bias integrator. Position/velocity: strapdown integration of R·f + g·e3,
// pulled towards GPS position and velocity and towards the barometer's altitude.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include "hexsim/magnetics/wmm.h"
#include "hexsim/nav/estimator.h"
#include "hexsim/sim/run_config.h"
#include "hexsim/sim/simulation.h"

namespace {

constexpr double kG = 9.80665;

double Wrap(double a) { return std::atan2(std::sin(a), std::cos(a)); }

struct SimpleGains {
  double tilt_kp = 1.0;       // 1/s
  double yaw_kp = 0.3;        // 1/s
  double bias_ki = 0.02;      // 1/s²
  // Second-order position loop per GPS sample (5 Hz): p += k_p·Δp, v += k_pv·Δp (ω ≈ 1 rad/s, ζ ≈ 1).
  double gps_pos = 0.4;
  double gps_pos_to_vel = 0.2;  // m/s per m
  double gps_vel = 0.3;         // fraction of the velocity error taken per GPS sample
  double gps_accel_lowpass = 0.5;  // weight of a new GPS acceleration sample
  double baro = 0.05;         // fraction of the altitude error per baro sample
  double align_s = 1.0;
};

class SimpleEstimator final : public hexsim::nav::Estimator {
 public:
  SimpleEstimator(const hexsim::nav::EarthFieldReference& earth, const SimpleGains& k) : earth_(earth), k_(k) {}

  std::string name() const override { return "example-mahony"; }

  void Reset(const hexsim::nav::NavEstimate& initial) override {
    x_ = initial;
    aligning_ = !initial.healthy;
    align_n_ = 0;
    align_t0_ = -1.0;
    sum_accel_.setZero();
    sum_gyro_.setZero();
    sum_mag_.setZero();
    bias_.setZero();
    last_t_ = -1.0;
    last_gps_t_ = -1.0;
    a_gps_N_.setZero();
  }

  void PredictImu(const hexsim::nav::ImuSample& s) override {
    if (!s.gyro_B_radps.allFinite() || !s.accel_B_mps2.allFinite()) return;
    if (aligning_) {
      if (align_t0_ < 0) align_t0_ = s.t_s;
      sum_accel_ += s.accel_B_mps2;
      sum_gyro_ += s.gyro_B_radps;
      ++align_n_;
      if (s.t_s - align_t0_ >= k_.align_s && align_n_ > 10 && sum_mag_.norm() > 0) FinishAlignment();
      last_t_ = s.t_s;
      return;
    }
    const double dt = last_t_ < 0 ? 0.0 : s.t_s - last_t_;
    last_t_ = s.t_s;
    if (dt <= 0 || dt > 0.1) return;
    const Eigen::Matrix3d R = x_.q_NB.toRotationMatrix();
    Eigen::Vector3d correction = Eigen::Vector3d::Zero();
    const double f = s.accel_B_mps2.norm();
    if (std::fabs(f - kG) < 0.3 * kG) {  // trust the accelerometer's direction near 1 g only
      const Eigen::Vector3d a_hat = s.accel_B_mps2 / f;
      const Eigen::Vector3d v_hat = (R.transpose() * (a_gps_N_ - Eigen::Vector3d(0, 0, kG))).normalized();
      correction += k_.tilt_kp * a_hat.cross(v_hat);
    }
    correction += k_.yaw_kp * yaw_error_rad_ * (R.transpose() * Eigen::Vector3d(0, 0, 1));
    bias_ -= k_.bias_ki * correction * dt;
    const Eigen::Vector3d w = s.gyro_B_radps - bias_ + correction;
    const double angle = w.norm() * dt;
    if (angle > 0) x_.q_NB = (x_.q_NB * Eigen::Quaterniond(Eigen::AngleAxisd(angle, w.normalized()))).normalized();
    const Eigen::Vector3d a_N = x_.q_NB.toRotationMatrix() * s.accel_B_mps2 + Eigen::Vector3d(0, 0, kG);
    x_.p_N_m += x_.v_N_mps * dt + 0.5 * a_N * dt * dt;
    x_.v_N_mps += a_N * dt;
    x_.w_B_radps = s.gyro_B_radps - bias_;
    x_.gyro_bias_B_radps = bias_;
    x_.t_s = s.t_s;
    ++stats_.imu_samples;
  }

  void FuseMag(const hexsim::nav::MagSample& m) override {
    if (!m.mag_B_uT.allFinite()) return;
    if (aligning_) {
      sum_mag_ += m.mag_B_uT;
      return;
    }
    const Eigen::Vector3d e = EulerZyx();
    const double psi = hexsim::nav::TiltCompensatedHeadingRad(m.mag_B_uT, e.x(), e.y()) + hexsim::nav::DeclinationRad(earth_);
    yaw_error_rad_ = Wrap(psi - e.z());  // held until the next compass sample
    ++stats_.mag.fused;
  }

  void FuseGps(const hexsim::nav::GpsSample& g) override {
    if (aligning_ || !g.p_N_m.allFinite() || !g.v_N_mps.allFinite()) return;
    const Eigen::Vector3d dp = g.p_N_m - x_.p_N_m;
    x_.p_N_m.head<2>() += k_.gps_pos * dp.head<2>();
    x_.v_N_mps += k_.gps_vel * (g.v_N_mps - x_.v_N_mps);
    x_.v_N_mps.head<2>() += k_.gps_pos_to_vel * dp.head<2>();
    if (last_gps_t_ >= 0 && g.t_s > last_gps_t_) {
      const Eigen::Vector3d a = (g.v_N_mps - last_gps_v_) / (g.t_s - last_gps_t_);
      a_gps_N_ += k_.gps_accel_lowpass * (a - a_gps_N_);
    }
    last_gps_t_ = g.t_s;
    last_gps_v_ = g.v_N_mps;
    ++stats_.gps_pos.fused;
  }

  void FuseBaro(const hexsim::nav::BaroSample& b) override {
    if (aligning_ || !std::isfinite(b.alt_m)) return;
    const double d = -b.alt_m - x_.p_N_m.z();
    x_.p_N_m.z() += k_.baro * d;
    x_.v_N_mps.z() += 0.02 * d;
    ++stats_.baro.fused;
  }

  hexsim::nav::NavEstimate Estimate() const override { return x_; }
  hexsim::Status Health() const override {
    if (!x_.p_N_m.allFinite() || !x_.v_N_mps.allFinite() || !x_.q_NB.coeffs().allFinite()) {
      return hexsim::Status::Numerical("example-mahony: non-finite state");
    }
    return hexsim::Status::Ok();
  }
  hexsim::nav::EstimatorStats Stats() const override { return stats_; }

 private:
  Eigen::Vector3d EulerZyx() const {
    const Eigen::Matrix3d R = x_.q_NB.toRotationMatrix();
    return Eigen::Vector3d(std::atan2(R(2, 1), R(2, 2)), -std::asin(std::clamp(R(2, 0), -1.0, 1.0)),
                           std::atan2(R(1, 0), R(0, 0)));
  }

  void FinishAlignment() {
    const Eigen::Vector3d f = sum_accel_ / align_n_;  // ≈ −g along body-down when level
    const double roll = std::atan2(-f.y(), -f.z());
    const double pitch = std::atan2(f.x(), std::sqrt(f.y() * f.y() + f.z() * f.z()));
    const double yaw =
        hexsim::nav::TiltCompensatedHeadingRad(sum_mag_.normalized(), roll, pitch) + hexsim::nav::DeclinationRad(earth_);
    x_.q_NB = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
              Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
    bias_ = sum_gyro_ / align_n_;
    x_.healthy = true;
    aligning_ = false;
  }

  hexsim::nav::EarthFieldReference earth_;
  SimpleGains k_;
  hexsim::nav::NavEstimate x_;
  hexsim::nav::EstimatorStats stats_;
  bool aligning_ = true;
  int align_n_ = 0;
  double align_t0_ = -1.0, last_t_ = -1.0, yaw_error_rad_ = 0.0, last_gps_t_ = -1.0;
  Eigen::Vector3d last_gps_v_ = Eigen::Vector3d::Zero(), a_gps_N_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d sum_accel_ = Eigen::Vector3d::Zero(), sum_gyro_ = Eigen::Vector3d::Zero(),
                  sum_mag_ = Eigen::Vector3d::Zero(), bias_ = Eigen::Vector3d::Zero();
};

}  // namespace

int main() {
  hexsim::sim::RunRequest request;  // worlds/ from HEXSIM_DATA_DIR (the installed share/hexsim)
  request.mission = "square";
  request.vehicle = "default_hex";
  request.estimator = "truth";  // replaced below
  request.seed = 5;
  auto setup = hexsim::sim::LoadRunSetup(request);
  if (!setup.ok()) {
    std::fprintf(stderr, "custom_estimator: %s\n", setup.status().message().c_str());
    return 2;
  }
  // The autopilot knows the model field at home (WMM), not local anomalies.
  const auto& w = setup->world;
  auto field = hexsim::magnetics::EvaluateWmm({w.home_lat_deg, w.home_lon_deg, w.home_alt_m}, w.date_decimal_year,
                                              w.allow_field_extrapolation);
  if (!field.ok()) {
    std::fprintf(stderr, "custom_estimator: %s\n", field.status().message().c_str());
    return 2;
  }
  hexsim::nav::EarthFieldReference earth;
  earth.B_N_uT = field->B_N_uT;
  hexsim::sim::Plugins plugins;
  plugins.estimator = std::make_unique<SimpleEstimator>(earth, SimpleGains{});
  auto sim = hexsim::sim::Simulation::Create(*setup, std::move(plugins));
  if (!sim.ok()) {
    std::fprintf(stderr, "custom_estimator: %s\n", sim.status().message().c_str());
    return 2;
  }
  double max_pos_err_m = 0.0;
  while ((*sim)->Step()) {
    if ((*sim)->estimate().healthy) {
      max_pos_err_m = std::max(max_pos_err_m, ((*sim)->estimate().p_N_m - (*sim)->true_state().p_N_m).norm());
    }
  }
  const hexsim::sim::RunOutput out = (*sim)->Finish();
  const auto& s = out.summary;
  std::printf("custom estimator %s, square: %s (%s) in %.1f s, cross-track rms %.2f m, yaw error rms %.2f deg, "
              "max position error %.2f m\n",
              s.estimator.c_str(), hexsim::sim::RunStatusName(s.status), s.reason.c_str(), s.duration_s,
              s.cross_track_m.rms, s.yaw_error_deg.rms, max_pos_err_m);
  // Completion, with the estimate good enough to follow the legs (uncalibrated compass: a few degrees).
  const bool ok = s.status == hexsim::sim::RunStatus::kCompleted && s.yaw_error_deg.rms < 15.0 &&
                  s.cross_track_m.rms < 5.0;
  return ok ? 0 : 1;
}
