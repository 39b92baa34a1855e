// The configured compass model at the logged compass samples on a trial timing (see
// compass_sampler.h).
#include "compass_sampler.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

namespace hexsim::gap::internal {
namespace {

// Between two log rows the current is unknown; where it jumps (motor spin-up, touchdown) the
// interpolated current cannot predict the wiring field, so such samples are left out. The same
// bound applies to each motor's share of it between the two rows around a sample (a manoeuvre that
// moves the split faster than the rows resolve it).
constexpr double kMaxCurrentStep_A = 2.0;

// A PX4 log's raw sensor_mag is in the sensor's own frame and holds its hard iron; PX4 calibrates it
// as R·S·(raw − off) (meta compasses[].px4_calibration, ulog_import.h; the power compensation, when
// CAL_MAG_COMP_TYP is set, is left in). gap reads every real log as the autopilot's calibrated field,
// so the raw column is calibrated the same way. Identity and zero for every other log (ArduPilot and
// calibrated PX4 topics log the calibrated body-frame field).
struct LoggedToCalibrated {
  Eigen::Matrix3d M = Eigen::Matrix3d::Identity();
  Vec3 off_uT = Vec3::Zero();
};

LoggedToCalibrated Px4Calibration(const nlohmann::json& meta, const std::string& pre) {
  constexpr double kMicroteslaPerGauss = 100.0;
  LoggedToCalibrated out;
  if (!meta.is_object() || !meta.contains("compasses") || !meta["compasses"].is_array()) return out;
  for (const auto& c : meta["compasses"]) {
    if (!c.is_object() || c.value("column", "") != pre || c.value("frame", "") != "raw" || !c.contains("px4_calibration")) continue;
    const auto& p = c["px4_calibration"];
    if (!p.is_object() || !p.value("rotation_known", false)) continue;
    const auto& r = p.value("rotation_matrix", nlohmann::json());
    const auto& d = p.value("scales", nlohmann::json());
    const auto& o = p.value("offdiagonals", nlohmann::json());
    const auto& f = p.value("offsets_G", nlohmann::json());
    if (!r.is_array() || r.size() != 9 || !d.is_array() || d.size() != 3 || !o.is_array() || o.size() != 3 ||
        !f.is_array() || f.size() != 3) {
      continue;
    }
    Eigen::Matrix3d R, S;
    for (size_t k = 0; k < 9; ++k) R(static_cast<int>(k / 3), static_cast<int>(k % 3)) = r[k].get<double>();
    S << d[0].get<double>(), o[0].get<double>(), o[1].get<double>(), o[0].get<double>(), d[1].get<double>(),
        o[2].get<double>(), o[1].get<double>(), o[2].get<double>(), d[2].get<double>();
    const Vec3 off = kMicroteslaPerGauss * Vec3(f[0].get<double>(), f[1].get<double>(), f[2].get<double>());
    if (R.allFinite() && S.allFinite() && off.allFinite()) out = {R * S, off};
  }
  return out;
}

// New compass samples: where the time stamp (or, without one, the value) changes; the autopilot's
// logged per-sample motor compensation is subtracted where the log has it; a PX4 raw reading is
// calibrated as PX4 does (Px4Calibration).
std::vector<CompassSample> NewSamples(const logs::FlightLog& log, const std::string& pre, bool* undone) {
  const LoggedToCalibrated cal = Px4Calibration(log.meta, pre);
  const auto& t_row = log.Column("t_s");
  const auto& mx = log.Column(pre + "_x_uT");
  const auto& my = log.Column(pre + "_y_uT");
  const auto& mz = log.Column(pre + "_z_uT");
  const std::vector<double>* mt = Col(log, pre + "_t_s");
  const std::vector<double>* ox = Col(log, pre + "_mot_x_uT");
  const std::vector<double>* oy = Col(log, pre + "_mot_y_uT");
  const std::vector<double>* oz = Col(log, pre + "_mot_z_uT");
  *undone = ox && oy && oz;
  std::vector<CompassSample> out;
  double last_t = -1e300;
  Vec3 last_v(std::nan(""), std::nan(""), std::nan(""));
  for (size_t i = 0; i < log.rows(); ++i) {
    Vec3 m(mx[i], my[i], mz[i]);
    if (!m.allFinite()) continue;
    double tm = t_row[i];
    if (mt) {
      if (!std::isfinite((*mt)[i]) || (*mt)[i] <= last_t) continue;
      tm = (*mt)[i];
      last_t = tm;
    } else {
      if (m == last_v) continue;
      last_v = m;
    }
    if (*undone) {
      const Vec3 o((*ox)[i], (*oy)[i], (*oz)[i]);
      if (o.allFinite()) m -= o;  // logged = M·(raw + offsets) + motor offsets
    }
    out.push_back({tm, Vec3(cal.M * (m - cal.off_uT)), static_cast<int>(i)});
  }
  return out;
}

}  // namespace

CompassSampler::CompassSampler(const logs::FlightLog& log, const vehicle::VehicleParams& v, size_t c, const LogInputs& in,
                               const Vec3& B_N_uT, bool calibrated_log, double share_exponent)
    : share_exponent_(std::clamp(share_exponent, kShareExponentLo, kShareExponentHi)),
      in_(in), v_(v), t_row_(log.Column("t_s")), B_N_uT_(B_N_uT), cur_{t_row_}, cur_i_{t_row_}, cur_r_{t_row_} {
  const vehicle::CompassParams& cp = v.compasses[c];
  wiring_ = v.wiring;
  if (cp.current_lag_tau_s >= 0) wiring_.lag_tau_s = cp.current_lag_tau_s;
  field_ = magnetics::FixedPointCurrentField(wiring_, cp.position_B_m);
  // A log whose compass values the autopilot calibrated carries no hard or soft iron of its own:
  // the configured sensor errors are not applied to it (orientation and wiring field are).
  err_ = cp.error;
  if (calibrated_log) {
    err_.hard_iron_uT.setZero();
    err_.soft_iron.setIdentity();
    err_.scale = 1.0;
  }
  samples_ = NewSamples(log, MagPrefix(c), &undone_);
  // How the motors share the battery current when the log has no per-motor currents, from the motor
  // outputs u_i: I_i ∝ u_i^p (kShareExponent; p fitted by Diagnose). A row without
  // (finite) outputs has none: the motors share equally there. A manoeuvre that spins two motors up
  // and two down moves the per-motor wiring fields while the battery current barely changes; an
  // equal split cannot predict that.
  // Only needed where the log has a battery current and no per-motor currents.
  if (SplitsBatteryCurrent(in, v)) n_motor_ = v.rotors.size();
  const size_t rows = t_row_.size();
  row_share_.assign(rows * n_motor_, 0.0);
  row_share_ok_.assign(rows, false);
  share_step_.assign(rows, 0.0);
  share_.reserve(n_motor_);
  for (size_t i = 0; n_motor_ > 0 && i < rows; ++i) {
    if (SharesAt(i, 0.0)) {
      std::copy(share_.begin(), share_.end(), row_share_.begin() + static_cast<std::ptrdiff_t>(i * n_motor_));
      row_share_ok_[i] = true;
    }
  }
  for (size_t i = 0; i + 1 < rows; ++i) {
    if (!row_share_ok_[i] || !row_share_ok_[i + 1]) continue;
    double step = 0;
    for (size_t m = 0; m < n_motor_; ++m) {
      step = std::max(step, std::fabs(row_share_[(i + 1) * n_motor_ + m] - row_share_[i * n_motor_ + m]));
    }
    share_step_[i] = step;
  }
}

// The motors' shares at row i, weight w to the next, into share_; false (share_ empty) without
// finite outputs or with every output at zero.
bool CompassSampler::SharesAt(size_t i, double w) {
  share_.clear();
  if (n_motor_ == 0) return false;
  double sum = 0;
  for (size_t m = 0; m < n_motor_; ++m) {
    const double u = Lerp(*in_.motor_u[m], i, w);
    if (!std::isfinite(u)) {
      share_.clear();
      return false;
    }
    const double uc = std::clamp(u, 0.0, 1.0);
    share_.push_back(share_exponent_ == kShareExponentHi ? uc * uc * uc : std::pow(uc, share_exponent_));
    sum += share_.back();
  }
  if (!(sum > 0)) {
    share_.clear();
    return false;
  }
  for (double& x : share_) x /= sum;
  return true;
}

void CompassSampler::Begin(double latency_s, double current_shift_s, double reach_s) {
  latency_s_ = latency_s;
  current_shift_s_ = current_shift_s;
  reach_s_ = reach_s;
  cur_.i = cur_i_.i = cur_r_.i = 0;
  lag_ = magnetics::CurrentLagState();
  first_ = true;
  prev_t_ = 0;
}

bool CompassSampler::Locate(const CompassSample& s, LocatedSample* out) {
  const double ta = s.t - latency_s_;  // when the field was measured
  double w = 0, wi = 0, wr = 0;
  if (!cur_.Seek(ta, &w) || !cur_i_.Seek(ta + current_shift_s_, &wi) || !cur_r_.Seek(ta + reach_s_, &wr)) {
    return false;
  }
  const size_t i = cur_.i;
  out->i = i;
  out->w = w;
  out->q = QuatLerp(in_.q, i, w);
  if (!out->q.coeffs().allFinite()) return false;
  // The current on the aligned time base, split by the motor outputs when the field was measured
  // (where the log has a battery current but no per-motor ones).
  const bool has_current = in_.current != nullptr;
  bool shares = false;
  if (n_motor_ > 0) {
    if (w <= 0) {
      shares = row_share_ok_[i];
      share_.assign(row_share_.begin() + static_cast<std::ptrdiff_t>(i * n_motor_),
                    row_share_.begin() + static_cast<std::ptrdiff_t>((i + 1) * n_motor_));
      if (!shares) share_.clear();
    } else {
      shares = SharesAt(i, w);
    }
  }
  magnetics::Currents& cu = out->currents;
  const size_t n_rot = v_.rotors.size();
  const size_t ic = cur_i_.i;
  cu.battery_A = has_current ? Lerp(*in_.current, ic, wi) : 0.0;
  cu.motor_A.assign(n_rot, 0.0);
  if (!in_.motor_A.empty()) {
    for (size_t m = 0; m < n_rot; ++m) cu.motor_A[m] = Lerp(*in_.motor_A[m], ic, wi);
  } else if (has_current) {
    const double motors = std::max(0.0, cu.battery_A - v_.avionics_current_A);
    for (size_t m = 0; m < n_rot; ++m) {
      cu.motor_A[m] = shares && share_.size() == n_rot ? motors * share_[m] : motors / static_cast<double>(n_rot);
    }
  }
  out->i_logged = has_current ? Lerp(*in_.current, i, w) : 0.0;
  const double i_reach = has_current ? Lerp(*in_.current, cur_r_.i, wr) : 0.0;
  bool ok = std::isfinite(cu.battery_A) && std::isfinite(out->i_logged) && std::isfinite(i_reach);
  if (has_current && wi > 0 && std::fabs((*in_.current)[ic + 1] - (*in_.current)[ic]) > kMaxCurrentStep_A) return false;
  if (shares && w > 0) {
    const double motors_A = std::max(0.0, cu.battery_A - v_.avionics_current_A);
    if (row_share_ok_[i] != row_share_ok_[i + 1] || motors_A * share_step_[i] > kMaxCurrentStep_A) return false;
  }
  for (double a : cu.motor_A) ok = ok && std::isfinite(a);
  return ok;
}

CompassSampler::Prediction CompassSampler::Predict(const CompassSample& s, const LocatedSample& ls,
                                                   const Eigen::Matrix3d& R_NB) {
  const double dt = first_ ? 0.0 : std::max(0.0, s.t - prev_t_);
  first_ = false;
  prev_t_ = s.t;
  const magnetics::Currents& lagged = magnetics::StepCurrentLag(wiring_, ls.currents, dt, &lag_);
  Prediction p;
  p.pred = magnetics::ApplyCompassError(err_, R_NB.transpose() * B_N_uT_ + field_(lagged), lagged.battery_A);
  p.h = p.pred - err_.hard_iron_uT;
  p.M = err_.R_SB * (err_.scale * (err_.soft_iron + lagged.battery_A * err_.soft_iron_per_A));
  return p;
}

}  // namespace hexsim::gap::internal
