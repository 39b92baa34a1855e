#include "hexsim/nav/eskf.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "hexsim/common/rotation.h"
#include "front_end.h"

namespace hexsim::nav {
namespace {

using Mat15 = Eigen::Matrix<double, 15, 15>;
using Vec15 = Eigen::Matrix<double, 15, 1>;
using Row15 = Eigen::Matrix<double, 1, 15>;

// Error-state indices.
constexpr int kTh = 0, kV = 3, kP = 6, kBg = 9, kBa = 12;
// Sine of the pitch beyond which the heading is undefined and the compass is not fused.
constexpr double kMaxHeadingCosPitch2 = 1e-4;
// 3-axis compass fusion is linearised about the current attitude: until the yaw is known to this
// accuracy the compass is fused as a heading (as EKF2 aligns yaw before 3-axis fusion).
constexpr double kThreeAxisMaxYawStd_rad = 5.0 * kDegToRad;

// P·hᵀ from the non-zero entries of the measurement row h (rows have one to three).
Vec15 SparseTimes(const Mat15& P, const Row15& h) {
  Vec15 out = Vec15::Zero();
  for (int j = 0; j < 15; ++j) {
    if (h(j) != 0.0) out += P.col(j) * h(j);
  }
  return out;
}

// The same from P's upper triangle (P symmetric, its lower triangle not yet mirrored): the same
// products summed in the same order as SparseTimes on the mirrored P.
Vec15 SparseTimesUpper(const Mat15& P, const Row15& h) {
  Vec15 out = Vec15::Zero();
  for (int j = 0; j < 15; ++j) {
    if (h(j) == 0.0) continue;
    for (int r = 0; r < 15; ++r) out(r) += (r <= j ? P(r, j) : P(j, r)) * h(j);
  }
  return out;
}

class Eskf final : public Estimator, private internal::Filter {
 public:
  explicit Eskf(const NavParams& params) : prm_(params) { Reset(NavEstimate()); }

  std::string name() const override { return "eskf"; }

  void Reset(const NavEstimate& initial) override {
    q_ = initial.q_NB.normalized();
    v_ = initial.v_N_mps;
    p_ = initial.p_N_m;
    bg_ = initial.gyro_bias_B_radps;
    ba_ = initial.accel_bias_B_mps2;
    w_B_ = Eigen::Vector3d::Zero();
    front_.Reset(initial);
    cov_dt_ = 0;
    cov_dv_N_.setZero();
    cov_count_ = 0;
    last_gps_fused_t_ = front_.time();
    last_gps_vel_fused_t_ = front_.time();
    last_mag_fused_t_ = front_.time();
    InitCovariance();
  }

  void PredictImu(const ImuSample& s) override {
    if (!front_.AdmitImu(s, prm_.align_time_s, this)) return;
    const double dt = std::min(s.t_s - front_.time(), internal::kMaxImuDt_s);
    const Eigen::Vector3d w = s.gyro_B_radps - bg_;
    const Eigen::Vector3d f_B = s.accel_B_mps2 - ba_;
    const Eigen::Matrix3d R = q_.toRotationMatrix();
    const Eigen::Vector3d f_N = R * f_B;
    const Eigen::Vector3d a_N = f_N + Eigen::Vector3d(0, 0, kGravity_mps2);
    // Nominal propagation: p ← p + v dt + a dt²/2, v ← v + a dt, q ← q ⊗ exp(ω dt).
    const Eigen::Vector3d p_new = p_ + v_ * dt + 0.5 * a_N * dt * dt;
    const Eigen::Vector3d v_new = v_ + a_N * dt;
    const Eigen::Quaterniond q_new = (q_ * QuatExp(w * dt)).normalized();
    // One test of the ten numbers first (a finite sum proves each finite); only when it fails the
    // checks one by one, which name the quantity.
    const bool ok = std::isfinite(p_new.sum() + v_new.sum() + q_new.coeffs().sum()) &&
                    internal::FrontEnd::SpeedOk(v_new);
    if (!ok && (!front_.CheckFinite(p_new, "p_N_m", s.t_s, "IMU predict") ||
                !front_.CheckFinite(v_new, "v_N_mps", s.t_s, "IMU predict") ||
                !front_.CheckFinite(q_new.coeffs(), "q_NB", s.t_s, "IMU predict") ||
                !front_.CheckSpeed(v_new, s.t_s, "IMU predict"))) {
      return;
    }
    p_ = p_new;
    v_ = v_new;
    q_ = q_new;
    w_B_ = w;
    front_.Advance(s.t_s);
    // The covariance runs at the filter rate on the accumulated interval: Δt = Σ dt and the
    // delta velocity Δv_N = Σ R·f·dt (as EKF2 and EKF3 down-sample delta angles and velocities).
    cov_dt_ += dt;
    cov_dv_N_ += f_N * dt;
    ++cov_count_;
    // Due once the interval reaches the filter period, less half this sample's dt (EKF3's test, so a
    // 400 Hz IMU gives exactly every 4th sample at 100 Hz), and at least every_n samples.
    const bool rate_due = prm_.cov_predict_rate_hz <= 0 || cov_dt_ >= 1.0 / prm_.cov_predict_rate_hz - 0.5 * dt;
    if (rate_due && cov_count_ >= prm_.cov_predict_every_n) FlushCovariance(R);
    front_.Record(p_, v_);
  }

  void FuseMag(const MagSample& s) override {
    if (!front_.AdmitMag(s, prm_.align_time_s, this)) return;
    EstimatorStats& stats = front_.stats();
    const Eigen::Matrix3d R = q_.toRotationMatrix();
    if (prm_.mag_mode == MagMode::kThreeAxis && Cov()(kTh + 2, kTh + 2) < kThreeAxisMaxYawStd_rad * kThreeAxisMaxYawStd_rad) {
      const Eigen::Vector3d& B_N = prm_.earth.B_N_uT;
      const Eigen::Vector3d h = R.transpose() * B_N;
      // h(δθ) = Rᵀ(I − [δθ]×)B_N = h + Rᵀ[B_N]× δθ
      const Eigen::Matrix3d H_th = R.transpose() * Skew(B_N);
      Row15 H[3];
      double y[3], r[3];
      for (int i = 0; i < 3; ++i) {
        H[i].setZero();
        H[i].segment<3>(kTh) = H_th.row(i);
        y[i] = s.mag_B_uT(i) - h(i);
        r[i] = prm_.mag_std_uT * prm_.mag_std_uT;
      }
      double ratio = 0;
      const bool fused = FuseGroup(3, H, y, r, prm_.mag_gate_sigma, s.t_s, "mag", &ratio);
      Count(&stats.mag, fused, Eigen::Vector3d(y[0], y[1], y[2]), ratio);
      if (fused) {
        last_mag_fused_t_ = s.t_s;
      } else if (s.t_s - last_mag_fused_t_ > prm_.mag_yaw_reset_timeout_s) {
        const Eigen::Vector3d euler = EulerFromQuat(q_);
        const double psi_meas =
            TiltCompensatedHeadingRad(s.mag_B_uT, euler.x(), euler.y()) + declination_rad_;
        ResetYaw(WrapPi(psi_meas - euler.z()), prm_.mag_heading_std_rad * prm_.mag_heading_std_rad);
        last_mag_fused_t_ = s.t_s;
      }
      return;
    }
    // Heading. The compass is levelled with the *estimated* roll/pitch, so with R_true = (I + [δθ]×)R
    // the levelled field is Rz(ψ̂)ᵀ(I − [δθ]×)B_N and the innovation ψ_meas − ψ̂ is
    //   y = δθ_D − B_D (B_N δθ_N + B_E δθ_E) / B_H²
    // (a tilt error leaks into the heading through the vertical field, ×tan(inclination)).
    const Eigen::Vector3d r0 = R.col(0);
    if (r0.x() * r0.x() + r0.y() * r0.y() < kMaxHeadingCosPitch2) {
      ++stats.mag.rejected_invalid;
      return;
    }
    const Eigen::Vector3d euler = EulerFromQuat(q_);
    const double psi_meas =
        TiltCompensatedHeadingRad(s.mag_B_uT, euler.x(), euler.y()) + declination_rad_;
    const Eigen::Vector3d& B = prm_.earth.B_N_uT;
    const double bh2 = B.x() * B.x() + B.y() * B.y();
    Row15 H = Row15::Zero();
    H(kTh + 0) = -B.z() * B.x() / bh2;
    H(kTh + 1) = -B.z() * B.y() / bh2;
    H(kTh + 2) = 1.0;
    double y = WrapPi(psi_meas - euler.z());
    double r = prm_.mag_heading_std_rad * prm_.mag_heading_std_rad;
    double ratio = 0;
    const bool fused = FuseGroup(1, &H, &y, &r, prm_.mag_gate_sigma, s.t_s, "mag heading", &ratio);
    Count(&stats.mag, fused, Eigen::Vector3d(y, 0, 0), ratio);
    if (fused) {
      last_mag_fused_t_ = s.t_s;
    } else if (s.t_s - last_mag_fused_t_ > prm_.mag_yaw_reset_timeout_s) {
      // The compass has disagreed for too long: the yaw, not the compass, is lost (a disturbed
      // compass rarely stays beyond the gate this long). Reset the yaw to it.
      ResetYaw(y, r);
      last_mag_fused_t_ = s.t_s;
    }
  }

  void FuseGps(const GpsSample& s) override {
    if (!front_.AdmitGps(s)) return;
    const double t_valid = s.t_s - prm_.gps_delay_s;
    Eigen::Vector3d p_then, v_then;
    if (!front_.LookupForGps(t_valid, p_, v_, &p_then, &v_then)) return;
    EstimatorStats& stats = front_.stats();
    // Position: horizontal and vertical gated apart (as EKF2), so a vertical GPS/baro disagreement
    // never locks the horizontal position out.
    const Eigen::Vector3d y_p = s.p_N_m - p_then;
    const double r_p = prm_.gps_pos_std_m * prm_.gps_pos_std_m;
    Row15 H[3];
    double y[3], r[3];
    for (int i = 0; i < 3; ++i) {
      H[i].setZero();
      H[i](kP + i) = 1.0;
      y[i] = y_p(i);
      r[i] = r_p;
    }
    double ratio_h = 0, ratio_v = 0;
    const bool fused_h = FuseGroup(2, H, y, r, prm_.gps_gate_sigma, s.t_s, "gps position", &ratio_h);
    if (!front_.healthy()) return;
    const bool fused_v = FuseGroup(1, &H[2], &y[2], &r[2], prm_.gps_gate_sigma, s.t_s, "gps height", &ratio_v);
    if (!front_.healthy()) return;
    Count(&stats.gps_pos, fused_h && fused_v, y_p, std::max(ratio_h, ratio_v));  // partly gated counts as gated
    if (fused_h) {
      last_gps_fused_t_ = t_valid;
    } else if (t_valid - last_gps_fused_t_ > prm_.gps_reset_timeout_s) {
      ResetToGps(s, p_then, v_then);
      last_gps_fused_t_ = t_valid;
      last_gps_vel_fused_t_ = t_valid;
      return;
    }
    // The position update moved the history too: take the velocity innovation after it.
    if (!front_.Lookup(t_valid, p_, v_, &p_then, &v_then)) return;
    const Eigen::Vector3d y_v = s.v_N_mps - v_then;
    for (int i = 0; i < 3; ++i) {
      H[i].setZero();
      H[i](kV + i) = 1.0;
      y[i] = y_v(i);
      r[i] = prm_.gps_vel_std_mps * prm_.gps_vel_std_mps;
    }
    double ratio = 0;
    const bool fused = FuseGroup(3, H, y, r, prm_.gps_gate_sigma, s.t_s, "gps velocity", &ratio);
    Count(&stats.gps_vel, fused, y_v, ratio);
    if (fused) {
      last_gps_vel_fused_t_ = t_valid;
    } else if (t_valid - last_gps_vel_fused_t_ > prm_.gps_reset_timeout_s) {
      // The position still passes its gate but the velocity has not for this long: the filter is
      // confident of a velocity the receiver keeps contradicting (a tilt error the velocity would
      // have corrected, drifting beyond the gate), and only a reset brings it back (EKF2's
      // resetVelocityToGnss when its velocity fusion times out).
      ResetVelocityToGps(s, v_then);
      last_gps_vel_fused_t_ = t_valid;
    }
  }

  void FuseBaro(const BaroSample& s) override {
    if (!front_.AdmitBaro(s)) return;
    EstimatorStats& stats = front_.stats();
    Row15 H = Row15::Zero();
    H(kP + 2) = -1.0;  // alt = −p_D
    double y = s.alt_m - (-p_.z());
    double r = prm_.baro_std_m * prm_.baro_std_m;
    double ratio = 0;
    const bool fused = FuseGroup(1, &H, &y, &r, prm_.baro_gate_sigma, s.t_s, "baro", &ratio);
    Count(&stats.baro, fused, Eigen::Vector3d(y, 0, 0), ratio);
  }

  NavEstimate Estimate() const override {
    NavEstimate e;
    e.t_s = front_.time();
    e.p_N_m = p_;
    e.v_N_mps = v_;
    e.w_B_radps = w_B_;
    e.gyro_bias_B_radps = bg_;
    e.accel_bias_B_mps2 = ba_;
    e.q_NB = q_;
    e.yaw_std_rad = std::sqrt(std::max(0.0, Cov()(kTh + 2, kTh + 2)));
    e.healthy = front_.healthy() && !front_.aligning();
    return e;
  }
  Status Health() const override { return front_.health(); }
  EstimatorStats Stats() const override { return front_.stats(); }

 private:
  // EKF2-style reset: horizontal position and velocity jump to the GPS sample (the offset found at
  // its time of validity is applied to the current state and the history); their covariance
  // becomes the GPS noise, uncorrelated with the rest.
  // Velocity only: it jumps to the GPS sample (the offset at its time of validity applied to the
  // current state and the history); its covariance becomes the GPS noise, uncorrelated.
  void ResetVelocityToGps(const GpsSample& s, const Eigen::Vector3d& v_then) {
    const Eigen::Vector3d dv = s.v_N_mps - v_then;
    v_ += dv;
    front_.Shift(Eigen::Vector3d::Zero(), dv);
    const double r_v = prm_.gps_vel_std_mps * prm_.gps_vel_std_mps;
    for (int i = 0; i < 3; ++i) ResetVariance(kV + i, r_v);
    ++front_.stats().gps_vel.resets;
  }

  void ResetToGps(const GpsSample& s, const Eigen::Vector3d& p_then, const Eigen::Vector3d& v_then) {
    const Eigen::Vector3d dp(s.p_N_m.x() - p_then.x(), s.p_N_m.y() - p_then.y(), 0.0);
    const Eigen::Vector3d dv = s.v_N_mps - v_then;
    p_ += dp;
    v_ += dv;
    front_.Shift(dp, dv);
    const double r_p = prm_.gps_pos_std_m * prm_.gps_pos_std_m;
    const double r_v = prm_.gps_vel_std_mps * prm_.gps_vel_std_mps;
    for (int i = 0; i < 3; ++i) ResetVariance(kV + i, r_v);
    for (int i = 0; i < 2; ++i) ResetVariance(kP + i, r_p);
    ++front_.stats().gps_pos.resets;
    ++front_.stats().gps_vel.resets;
  }

  void InitCovariance() {
    Vec15 d;
    const double tilt = prm_.init_tilt_std_rad, yaw = prm_.init_yaw_std_rad;
    d << tilt * tilt, tilt * tilt, yaw * yaw, Eigen::Vector3d::Constant(prm_.init_vel_std_mps * prm_.init_vel_std_mps),
        Eigen::Vector3d::Constant(prm_.init_pos_std_m * prm_.init_pos_std_m),
        Eigen::Vector3d::Constant(prm_.init_gyro_bias_std_radps * prm_.init_gyro_bias_std_radps),
        Eigen::Vector3d::Constant(prm_.init_accel_bias_std_mps2 * prm_.init_accel_bias_std_mps2);
    Cov() = d.asDiagonal();
  }

  void OnFirstImu(const ImuSample& s) override {
    w_B_ = s.gyro_B_radps - bg_;
    front_.Record(p_, v_);
  }

  void OnAligned() override {
    q_ = front_.aligner().Attitude(prm_.earth);
    bg_ = front_.aligner().GyroBias();
    last_gps_fused_t_ = front_.time();
    last_mag_fused_t_ = front_.time();
    InitCovariance();
    front_.FinishAlignment(p_, v_);
  }

  // Propagates the covariance over the accumulated interval, R the attitude at its end.
  void FlushCovariance(const Eigen::Matrix3d& R) {
    if (cov_count_ == 0) return;
    PredictCovariance(R, cov_dv_N_, cov_dt_);
    cov_dt_ = 0;
    cov_dv_N_.setZero();
    cov_count_ = 0;
  }

  // P ← F P Fᵀ + Q over dt; F = I + A dt (A as in the header) with f_N·dt = dv_N, Q from the noise
  // densities.
  __attribute__((noinline)) void PredictCovariance(const Eigen::Matrix3d& R, const Eigen::Vector3d& dv_N,
                                                   double dt) {
    // F = I except F_θ,bg = −R·dt (A), F_v,θ = −[Δv_N]× (B), F_v,ba = −R·dt (A), F_p,v = I·dt.
    // F·P·Fᵀ is written blockwise (3×3 by 3×15 products, no general 15×15 GEMM at 1 kHz), only
    // its upper block triangle, then mirrored: P stays exactly symmetric.
    using Rows3 = Eigen::Matrix<double, 3, 15>;
    const Eigen::Matrix3d A = -R * dt;
    const Eigen::Matrix3d B = -Skew(dv_N);
    const Mat15& P0 = Cov();
    // Row blocks of M = F·P (the bias rows of M are those of P).
    Rows3 M_th = P0.middleRows<3>(kTh);
    M_th.noalias() += A * P0.middleRows<3>(kBg);
    Rows3 M_v = P0.middleRows<3>(kV);
    M_v.noalias() += B * P0.middleRows<3>(kTh);
    M_v.noalias() += A * P0.middleRows<3>(kBa);
    const Rows3 M_p = P0.middleRows<3>(kP) + dt * P0.middleRows<3>(kV);
    // Column blocks of M·Fᵀ: col θ = M_θ + M_bg·Aᵀ; col v = M_v + M_θ·Bᵀ + M_ba·Aᵀ;
    // col p = M_p + dt·M_v; bias columns unchanged.
    const Eigen::Matrix3d At = A.transpose(), Bt = B.transpose();
    Mat15& P = SpareCov();
    P.block<3, 3>(kTh, kTh) = M_th.middleCols<3>(kTh) + M_th.middleCols<3>(kBg) * At;
    P.block<3, 3>(kTh, kV) = M_th.middleCols<3>(kV) + M_th.middleCols<3>(kTh) * Bt + M_th.middleCols<3>(kBa) * At;
    P.block<3, 3>(kTh, kP) = M_th.middleCols<3>(kP) + dt * M_th.middleCols<3>(kV);
    P.block<3, 6>(kTh, kBg) = M_th.middleCols<6>(kBg);
    P.block<3, 3>(kV, kV) = M_v.middleCols<3>(kV) + M_v.middleCols<3>(kTh) * Bt + M_v.middleCols<3>(kBa) * At;
    P.block<3, 3>(kV, kP) = M_v.middleCols<3>(kP) + dt * M_v.middleCols<3>(kV);
    P.block<3, 6>(kV, kBg) = M_v.middleCols<6>(kBg);
    P.block<3, 3>(kP, kP) = M_p.middleCols<3>(kP) + dt * M_p.middleCols<3>(kV);
    P.block<3, 6>(kP, kBg) = M_p.middleCols<6>(kBg);
    P.block<6, 6>(kBg, kBg) = P0.block<6, 6>(kBg, kBg);
    const double qg = prm_.gyro_noise_radps_rthz * prm_.gyro_noise_radps_rthz * dt;
    const double qa = prm_.accel_noise_mps2_rthz * prm_.accel_noise_mps2_rthz * dt;
    const double qbg = prm_.gyro_bias_rw_radps2_rthz * prm_.gyro_bias_rw_radps2_rthz * dt;
    const double qba = prm_.accel_bias_rw_mps3_rthz * prm_.accel_bias_rw_mps3_rthz * dt;
    for (int i = 0; i < 3; ++i) {  // isotropic noise: R Q Rᵀ = Q
      P(kTh + i, kTh + i) += qg;
      P(kV + i, kV + i) += qa;
      P(kBg + i, kBg + i) += qbg;
      P(kBa + i, kBa + i) += qba;
    }
    MirrorUpper(&P);
    if (!CheckCovariance(P, front_.time(), "covariance predict")) return;
    CommitSpareCov();
  }

  // Gates the group (every |y_i| ≤ gate·√S_ii), then fuses its components one by one (Joseph form),
  // then injects the accumulated error state into the nominal state and resets it. Returns whether
  // the group was fused; *test_ratio is the largest |y_i| / (gate·√S_ii).
  bool FuseGroup(int n, const Row15* H, const double* y, const double* r, double gate_sigma, double t_s,
                 const char* what, double* test_ratio) {
    double worst = 0;
    Vec15 PHt[3];  // P·Hᵢᵀ from the few non-zero entries of Hᵢ (groups have at most three rows)
    HEXSIM_CHECK(n >= 1 && n <= 3);
    for (int i = 0; i < n; ++i) {
      PHt[i] = SparseTimes(Cov(), H[i]);
      const double S = H[i].dot(PHt[i]) + r[i];
      worst = std::max(worst, std::abs(y[i]) / (gate_sigma * std::sqrt(S)));
    }
    *test_ratio = worst;
    if (!(worst <= 1.0)) return false;
    Vec15 dx = Vec15::Zero();
    Mat15& P = SpareCov();  // the first row's update reads Cov(), the next ones P
    for (int i = 0; i < n; ++i) {
      const Vec15 Pht = i == 0 ? PHt[0] : SparseTimesUpper(P, H[i]);
      const double S = H[i].dot(Pht) + r[i];
      const Vec15 K = Pht / S;
      dx += K * (y[i] - H[i].dot(dx));
      // Joseph form (I−KH)·P·(I−KH)ᵀ + K·r·Kᵀ; with P symmetric and HP = (PHᵀ)ᵀ it expands to
      //   P − K·(PHᵀ)ᵀ − (PHᵀ)·Kᵀ + (HPHᵀ + r)·K·Kᵀ,
      // evaluated on the upper triangle (O(n²)), mirrored once after the group: P stays exactly symmetric.
      JosephUpper(K, Pht, S, i == 0 ? Cov() : P, &P);
    }
    MirrorUpper(&P);
    const Eigen::Vector3d v_new = v_ + dx.segment<3>(kV);
    if (!internal::FrontEnd::Finite(dx) || !CovarianceOk(P) || !internal::FrontEnd::SpeedOk(v_new)) {
      // Named only when a check fails (no formatting per fusion): the same checks again, recording
      // which one failed and where.
      char where[48];
      std::snprintf(where, sizeof where, "%s update", what);
      if (front_.CheckFinite(dx, "error state", t_s, where) && CheckCovariance(P, t_s, where)) {
        front_.CheckSpeed(v_new, t_s, where);
      }
      return false;
    }
    // Injection: q ← exp(δθ)⊗q (δθ in N), additive for the rest. Reset of a *global* (N-frame)
    // attitude error: exp(δθ⁺) = exp(δθ)⊗exp(−δθ̂) ⇒ G_θθ = I + [δθ̂/2]× (I − [δθ̂/2]× is the local one).
    const Eigen::Vector3d dth = dx.segment<3>(kTh);
    q_ = (QuatExp(dth) * q_).normalized();
    v_ += dx.segment<3>(kV);
    p_ += dx.segment<3>(kP);
    bg_ += dx.segment<3>(kBg);
    ba_ += dx.segment<3>(kBa);
    front_.Shift(dx.segment<3>(kP), dx.segment<3>(kV));
    // P ← G·P·Gᵀ with G = I except G_θθ = I + [δθ̂/2]×: only the θ row and column blocks change.
    const Eigen::Matrix3d G = Eigen::Matrix3d::Identity() + Skew(0.5 * dth);
    ResetAttitudeBlock(G, &P);
    CommitSpareCov();
    return true;
  }

  // Records one measurement's outcome in its stats.
  static void Count(SensorStats* st, bool fused, const Eigen::Vector3d& innovation, double ratio) {
    st->last_innovation = innovation;
    st->last_test_ratio = ratio;
    if (fused) ++st->fused; else ++st->rejected_gate;
  }

  // Zeroes the cross-covariances of error-state index i and sets its variance (a state reset).
  void ResetVariance(int i, double variance) {
    Cov().row(i).setZero();
    Cov().col(i).setZero();
    Cov()(i, i) = variance;
  }

  // EKF2-style yaw reset: rotates the attitude about N down by the heading innovation.
  void ResetYaw(double dpsi_rad, double variance) {
    q_ = (QuatExp(Eigen::Vector3d(0, 0, dpsi_rad)) * q_).normalized();
    ResetVariance(kTh + 2, variance);
    ++front_.stats().mag.resets;
  }

  // The covariance steps below are kept out of line (noinline): inlined into PredictImu and
  // FuseGroup they cost ≈ 120 instructions per physics step more (sim_instructions full), the
  // callers' every call paying for the registers the 15×15 code needs.

  // P(r,c) = P(c,r) below the diagonal, unrolled at compile time (105 plain copies).
  template <int... I>
  static void MirrorUpperImpl(Mat15* P, std::integer_sequence<int, I...> /*unused*/) {
    double* d = P->data();
    (((I % 15) > (I / 15) ? void(d[I] = d[(I % 15) * 15 + I / 15]) : void()), ...);
  }
  __attribute__((noinline)) static void MirrorUpper(Mat15* P) {
    MirrorUpperImpl(P, std::make_integer_sequence<int, 225>());
  }

  // P += (HPHᵀ + r)·K·Kᵀ − K·(PHᵀ)ᵀ − (PHᵀ)·Kᵀ on the upper triangle: every entry (row ≤ c) is
  // P(row,c) + ((S·K(row))·K(c) − K(row)·Pht(c)) − Pht(row)·K(c). Column c is updated in rows
  // 0..c rounded up to an even count, so each column is whole vector packets; the one entry below
  // the diagonal this adds is overwritten by the mirror after the group and read by nothing before
  // (the next row's P·hᵀ reads the upper triangle).
  // *P = P0 + that (P0 may be *P: each entry reads only its own), and nothing else of *P is written.
  template <int C>
  static void JosephColumns(const Vec15& SK, const Vec15& K, const Vec15& Pht, const Mat15& P0, Mat15* P) {
    if constexpr (C < 15) {
      constexpr int kRows = std::min(15, (C + 2) / 2 * 2);
      P->col(C).template head<kRows>() = P0.col(C).template head<kRows>() +
          (SK.head<kRows>() * K(C) - K.head<kRows>() * Pht(C) - Pht.head<kRows>() * K(C));
      JosephColumns<C + 1>(SK, K, Pht, P0, P);
    }
  }
  __attribute__((noinline)) static void JosephUpper(const Vec15& K, const Vec15& Pht, double S, const Mat15& P0,
                                                    Mat15* P) {
    const Vec15 SK = S * K;
    JosephColumns<0>(SK, K, Pht, P0, P);
  }

  // P ← G·P·Gᵀ for G = I except the θθ block: only the θ row and column blocks change.
  __attribute__((noinline)) static void ResetAttitudeBlock(const Eigen::Matrix3d& G, Mat15* P) {
    P->middleRows<3>(kTh) = (G * P->middleRows<3>(kTh)).eval();
    P->middleCols<3>(kTh) = (P->middleCols<3>(kTh) * G.transpose()).eval();
  }

  // CheckCovariance's test without the failure.
  static bool CovarianceOk(const Mat15& P) {
    if (!internal::FrontEnd::Finite(P)) return false;
    for (int i = 0; i < 15; ++i) {
      if (P(i, i) < 0.0) return false;
    }
    return true;
  }

  const Mat15& Cov() const { return P_store_[p_current_]; }
  Mat15& Cov() { return P_store_[p_current_]; }
  Mat15& SpareCov() { return P_store_[1 - p_current_]; }
  void CommitSpareCov() { p_current_ = 1 - p_current_; }

  bool CheckCovariance(const Mat15& P, double t_s, const char* where) {
    static const char* kNames[15] = {"δθ_x", "δθ_y", "δθ_z", "δv_N", "δv_E", "δv_D", "δp_N", "δp_E",
                                     "δp_D", "δbg_x", "δbg_y", "δbg_z", "δba_x", "δba_y", "δba_z"};
    if (!front_.CheckFinite(P, "covariance", t_s, where)) return false;
    for (int i = 0; i < 15; ++i) {
      if (P(i, i) < 0.0) {
        front_.Fail("negative variance of " + std::string(kNames[i]) + " at t=" + internal::FrontEnd::Num(t_s) +
                    " s" + internal::FrontEnd::Where(where));
        return false;
      }
    }
    return true;
  }

  NavParams prm_;
  double declination_rad_ = DeclinationRad(prm_.earth);  // of the fixed reference field (an atan2 per sample)
  Eigen::Quaterniond q_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d v_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d bg_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d ba_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d w_B_ = Eigen::Vector3d::Zero();
  // The covariance, double-buffered: a predict or an update writes the spare and, when its checks
  // pass, makes it the current one (no 15×15 copy back).
  Mat15 P_store_[2] = {Mat15::Identity(), Mat15::Identity()};
  int p_current_ = 0;
  internal::FrontEnd front_{"eskf"};
  double cov_dt_ = 0;                                    // accumulated since the last covariance predict
  Eigen::Vector3d cov_dv_N_ = Eigen::Vector3d::Zero();  // Σ R·f·dt over the same interval
  int cov_count_ = 0;
  double last_gps_fused_t_ = 0;  // time of validity of the last fused horizontal GPS position
  double last_gps_vel_fused_t_ = 0;  // time of validity of the last fused GPS velocity
  double last_mag_fused_t_ = 0;
};

}  // namespace

std::unique_ptr<Estimator> MakeEskf(const NavParams& params) { return std::make_unique<Eskf>(params); }

}  // namespace hexsim::nav
