#include "hexsim/nav/complementary.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "hexsim/common/rotation.h"
#include "front_end.h"

namespace hexsim::nav {
namespace {

// The compass step never integrates a longer gap than this (a first sample after a dropout).
constexpr double kMaxMagDt_s = 0.2;
// The accelerometer tilt correction is used only while |f| is within this fraction of g.
constexpr double kAccelTrustBand = 0.2;
constexpr double kMinHeadingCosPitch2 = 1e-4;
// The kinematic acceleration reference: GPS velocity differences, low-passed with this time
// constant, forgotten when GPS stops for longer than kAccelRefTimeout_s.
constexpr double kAccelRefTau_s = 0.3;
constexpr double kAccelRefTimeout_s = 1.0;

class Complementary final : public Estimator, private internal::Filter {
 public:
  explicit Complementary(const NavParams& params) : prm_(params) { Reset(NavEstimate()); }

  std::string name() const override { return "complementary"; }

  void Reset(const NavEstimate& initial) override {
    q_ = initial.q_NB.normalized();
    v_ = initial.v_N_mps;
    p_ = initial.p_N_m;
    bg_ = initial.gyro_bias_B_radps;
    w_B_ = Eigen::Vector3d::Zero();
    last_mag_t_ = 0;
    have_mag_t_ = false;
    gps_rejections_in_row_ = 0;
    have_gps_v_ = have_a_ref_ = false;
    a_ref_N_.setZero();
    front_.Reset(initial);
  }

  void PredictImu(const ImuSample& s) override {
    if (!front_.AdmitImu(s, prm_.align_time_s, this)) return;
    const double dt = std::min(s.t_s - front_.time(), internal::kMaxImuDt_s);
    const Eigen::Matrix3d R = q_.toRotationMatrix();
    // Tilt error in N: φ = d_meas × d_ref with d_meas = R·f/|f| and d_ref the direction of the
    // specific force expected from the kinematic acceleration, f_ref = a_ref − g (a_ref from GPS;
    // zero without it). Taking f_ref = −g while the vehicle accelerates tilts the estimate by a/g.
    Eigen::Vector3d corr_B = Eigen::Vector3d::Zero();
    const double f_norm = s.accel_B_mps2.norm();
    const bool have_ref = have_a_ref_ && s.t_s - a_ref_t_ < kAccelRefTimeout_s;
    const Eigen::Vector3d f_ref_N =
        (have_ref ? a_ref_N_ : Eigen::Vector3d::Zero()) - Eigen::Vector3d(0, 0, kGravity_mps2);
    if (f_norm > 0 && std::abs(f_norm - f_ref_N.norm()) < kAccelTrustBand * kGravity_mps2) {
      const Eigen::Vector3d d_meas_N = R * (s.accel_B_mps2 / f_norm);
      const Eigen::Vector3d phi_N = d_meas_N.cross(f_ref_N.normalized());
      corr_B = R.transpose() * phi_N;
    }
    const Eigen::Vector3d w = s.gyro_B_radps - bg_ + prm_.comp_tilt_gain_radps * corr_B;
    const Eigen::Vector3d bg_new = bg_ - prm_.comp_bias_gain_rad * corr_B * dt;
    const Eigen::Vector3d a_N = R * s.accel_B_mps2 + Eigen::Vector3d(0, 0, kGravity_mps2);
    const Eigen::Vector3d p_new = p_ + v_ * dt + 0.5 * a_N * dt * dt;
    const Eigen::Vector3d v_new = v_ + a_N * dt;
    const Eigen::Quaterniond q_new = (q_ * QuatExp(w * dt)).normalized();
    if (!front_.CheckFinite(p_new, "p_N_m", s.t_s) || !front_.CheckFinite(v_new, "v_N_mps", s.t_s) ||
        !front_.CheckSpeed(v_new, s.t_s) || !front_.CheckFinite(q_new.coeffs(), "q_NB", s.t_s) ||
        !front_.CheckFinite(bg_new, "gyro_bias_B_radps", s.t_s)) {
      return;
    }
    p_ = p_new;
    v_ = v_new;
    q_ = q_new;
    bg_ = bg_new;
    w_B_ = s.gyro_B_radps - bg_;
    front_.Advance(s.t_s);
    front_.Record(p_, v_);
  }

  void FuseMag(const MagSample& s) override {
    if (!front_.AdmitMag(s, prm_.align_time_s, this)) return;
    EstimatorStats& stats = front_.stats();
    const double dt = have_mag_t_ ? std::clamp(s.t_s - last_mag_t_, 0.0, kMaxMagDt_s) : 0.0;
    last_mag_t_ = s.t_s;
    have_mag_t_ = true;
    const Eigen::Matrix3d R = q_.toRotationMatrix();
    const Eigen::Vector3d r0 = R.col(0);
    if (r0.x() * r0.x() + r0.y() * r0.y() < kMinHeadingCosPitch2) {
      ++stats.mag.rejected_invalid;
      return;
    }
    const Eigen::Vector3d euler = EulerFromQuat(q_);
    const double psi_meas =
        TiltCompensatedHeadingRad(s.mag_B_uT, euler.x(), euler.y()) + DeclinationRad(prm_.earth);
    const double e_yaw = WrapPi(psi_meas - euler.z());
    stats.mag.last_innovation = Eigen::Vector3d(e_yaw, 0, 0);
    stats.mag.last_test_ratio = 0;
    // Rotation about N down by Kp·dt·Δψ: q ← exp(e_D·Kp·dt·Δψ)⊗q; bias integrator on its body axis.
    const double step = std::min(1.0, prm_.comp_yaw_gain_radps * dt) * e_yaw;
    const Eigen::Quaterniond q_new = (QuatExp(Eigen::Vector3d(0, 0, step)) * q_).normalized();
    const Eigen::Vector3d bg_new =
        bg_ - prm_.comp_bias_gain_rad * dt * e_yaw * (R.transpose() * Eigen::Vector3d::UnitZ());
    if (!front_.CheckFinite(q_new.coeffs(), "q_NB", s.t_s) || !front_.CheckFinite(bg_new, "gyro_bias_B_radps", s.t_s)) {
      return;
    }
    q_ = q_new;
    bg_ = bg_new;
    ++stats.mag.fused;
  }

  void FuseGps(const GpsSample& s) override {
    if (!front_.AdmitGps(s)) return;
    const double t_valid = s.t_s - prm_.gps_delay_s;
    Eigen::Vector3d p_then, v_then;
    if (!front_.LookupForGps(t_valid, p_, v_, &p_then, &v_then)) return;
    EstimatorStats& stats = front_.stats();
    // Kinematic acceleration reference from successive GPS velocities (low-passed).
    if (have_gps_v_ && s.t_s > gps_v_t_) {
      const double dt = s.t_s - gps_v_t_;
      const Eigen::Vector3d a = (s.v_N_mps - gps_v_) / dt;
      if (!have_a_ref_ || s.t_s - a_ref_t_ > kAccelRefTimeout_s) a_ref_N_ = a;
      else a_ref_N_ += std::min(1.0, dt / kAccelRefTau_s) * (a - a_ref_N_);
      a_ref_t_ = s.t_s;
      have_a_ref_ = true;
    }
    gps_v_ = s.v_N_mps;
    gps_v_t_ = s.t_s;
    have_gps_v_ = true;
    const Eigen::Vector3d e_p = s.p_N_m - p_then;
    const Eigen::Vector3d e_v = s.v_N_mps - v_then;
    const double gate_p = prm_.gps_gate_sigma * std::hypot(prm_.gps_pos_std_m, prm_.comp_pos_std_m);
    const double gate_v = prm_.gps_gate_sigma * std::hypot(prm_.gps_vel_std_mps, prm_.comp_vel_std_mps);
    const double ratio_p = e_p.cwiseAbs().maxCoeff() / gate_p;
    const double ratio_v = e_v.cwiseAbs().maxCoeff() / gate_v;
    stats.gps_pos.last_innovation = e_p;
    stats.gps_pos.last_test_ratio = ratio_p;
    stats.gps_vel.last_innovation = e_v;
    stats.gps_vel.last_test_ratio = ratio_v;
    if (!(ratio_p <= 1.0) || !(ratio_v <= 1.0)) {
      if (!(ratio_p <= 1.0)) ++stats.gps_pos.rejected_gate;
      if (!(ratio_v <= 1.0)) ++stats.gps_vel.rejected_gate;
      if (++gps_rejections_in_row_ < prm_.comp_reset_after_rejections) return;
      // Persistent disagreement: the estimate is lost, not the receiver. Reset to GPS.
      Apply(e_p, e_v);
      gps_rejections_in_row_ = 0;
      return;
    }
    gps_rejections_in_row_ = 0;
    Apply(prm_.comp_pos_gain * e_p, prm_.comp_vel_from_pos_gain * e_p + prm_.comp_vel_gain * e_v);
    ++stats.gps_pos.fused;
    ++stats.gps_vel.fused;
  }

  void FuseBaro(const BaroSample& s) override {
    if (!front_.AdmitBaro(s)) return;
    EstimatorStats& stats = front_.stats();
    const double e = s.alt_m - (-p_.z());
    const double ratio = std::abs(e) / (prm_.baro_gate_sigma * std::hypot(prm_.baro_std_m, prm_.comp_pos_std_m));
    stats.baro.last_innovation = Eigen::Vector3d(e, 0, 0);
    stats.baro.last_test_ratio = ratio;
    if (!(ratio <= 1.0)) {
      ++stats.baro.rejected_gate;
      return;
    }
    Apply(Eigen::Vector3d(0, 0, -prm_.comp_baro_gain * e), Eigen::Vector3d::Zero());
    ++stats.baro.fused;
  }

  NavEstimate Estimate() const override {
    NavEstimate e;
    e.t_s = front_.time();
    e.p_N_m = p_;
    e.v_N_mps = v_;
    e.w_B_radps = w_B_;
    e.gyro_bias_B_radps = bg_;
    e.accel_bias_B_mps2 = Eigen::Vector3d::Zero();
    e.q_NB = q_;
    e.yaw_std_rad = prm_.mag_heading_std_rad;  // no covariance: the compass's own accuracy
    e.healthy = front_.healthy() && !front_.aligning();
    return e;
  }
  Status Health() const override { return front_.health(); }
  EstimatorStats Stats() const override { return front_.stats(); }

 private:
  void OnFirstImu(const ImuSample& s) override {
    w_B_ = s.gyro_B_radps - bg_;
    front_.Record(p_, v_);
  }

  void OnAligned() override {
    q_ = front_.aligner().Attitude(prm_.earth);
    bg_ = front_.aligner().GyroBias();
    front_.FinishAlignment(p_, v_);
  }

  void Apply(const Eigen::Vector3d& dp, const Eigen::Vector3d& dv) {
    p_ += dp;
    v_ += dv;
    front_.Shift(dp, dv);
  }

  NavParams prm_;
  Eigen::Quaterniond q_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d v_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d bg_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d w_B_ = Eigen::Vector3d::Zero();
  double last_mag_t_ = 0;
  bool have_mag_t_ = false;
  int gps_rejections_in_row_ = 0;
  Eigen::Vector3d gps_v_ = Eigen::Vector3d::Zero();  // last GPS velocity and its time
  double gps_v_t_ = 0;
  bool have_gps_v_ = false;
  Eigen::Vector3d a_ref_N_ = Eigen::Vector3d::Zero();  // low-passed kinematic acceleration
  double a_ref_t_ = 0;
  bool have_a_ref_ = false;
  internal::FrontEnd front_{"complementary"};
};

}  // namespace

std::unique_ptr<Estimator> MakeComplementary(const NavParams& params) {
  return std::make_unique<Complementary>(params);
}

}  // namespace hexsim::nav
