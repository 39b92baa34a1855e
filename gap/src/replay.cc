// Replay: drive the configured models with what the log says happened and build the residuals and
// the candidate effects' regressors per channel.
#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <fmt/format.h>

#include "channels.h"
#include "hexsim/common/rotation.h"
#include "hexsim/magnetics/compass_model.h"
#include "hexsim/magnetics/wmm.h"

namespace hexsim::gap::internal {
namespace {

constexpr double kThrottleFullScale = 1000.0;  // control_u units per full throttle
// Lag grid for the current_lag candidate (s): ESC/current filtering to slow magnetisation.
constexpr double kLagGrid_s[] = {0.01, 0.02, 0.03, 0.05, 0.07, 0.1, 0.14, 0.2, 0.28, 0.4, 0.56, 0.8, 1.1, 1.6, 2.2};

const std::vector<double>* Col(const logs::FlightLog& log, const std::string& name) {
  return log.Has(name) ? &log.Column(name) : nullptr;
}

bool ColumnHasData(const logs::FlightLog& log, const std::string& name) {
  if (!log.Has(name)) return false;
  for (double v : log.Column(name)) {
    if (std::isfinite(v)) return true;
  }
  return false;
}

// Linear interpolation of the log's rows at time tq (rows ascending in t). Returns false outside.
struct RowCursor {
  const std::vector<double>& t;
  size_t i = 0;
  // Sets (i, w) so that value = (1 − w)·v[i] + w·v[i + 1].
  bool Seek(double tq, double* w) {
    if (t.size() < 2 || tq < t.front() || tq > t.back()) return false;
    while (i + 2 < t.size() && t[i + 1] < tq) ++i;
    while (i > 0 && t[i] > tq) --i;
    const double dt = t[i + 1] - t[i];
    *w = dt > 0 ? std::clamp((tq - t[i]) / dt, 0.0, 1.0) : 0.0;
    return true;
  }
};

double Lerp(const std::vector<double>& v, size_t i, double w) {
  if (w <= 0) return v[i];
  return (1 - w) * v[i] + w * v[i + 1];
}

Eigen::Quaterniond QuatRow(const std::vector<const std::vector<double>*>& q, size_t i) {
  return Eigen::Quaterniond((*q[0])[i], (*q[1])[i], (*q[2])[i], (*q[3])[i]);
}

Eigen::Quaterniond QuatLerp(const std::vector<const std::vector<double>*>& q, size_t i, double w) {
  Eigen::Quaterniond a = QuatRow(q, i);
  if (w <= 0) return a.normalized();
  Eigen::Quaterniond b = QuatRow(q, i + 1);
  if (a.dot(b) < 0) b.coeffs() *= -1.0;
  Eigen::Quaterniond r;
  r.coeffs() = (1 - w) * a.coeffs() + w * b.coeffs();
  return r.normalized();
}

struct LogInputs {
  std::vector<const std::vector<double>*> q;
  const std::vector<double>* current = nullptr;
  std::vector<const std::vector<double>*> motor_A;
  std::vector<const std::vector<double>*> motor_u;
  const std::vector<double>* control_u = nullptr;
  const std::vector<double>* temp = nullptr;
  bool has_attitude = false;
};

Mat3X Diag3(double v) { return Mat3X(Eigen::Matrix3d::Identity() * v); }

// Central-difference derivative of a sample series (one-sided at the ends).
std::vector<Vec3> Derivative(const std::vector<double>& t, const std::vector<Vec3>& v) {
  std::vector<Vec3> d(v.size(), Vec3::Zero());
  for (size_t k = 0; k < v.size(); ++k) {
    const size_t a = k == 0 ? 0 : k - 1;
    const size_t b = k + 1 < v.size() ? k + 1 : k;
    const double dt = t[b] - t[a];
    if (dt > 0) d[k] = (v[b] - v[a]) / dt;
  }
  return d;
}

}  // namespace

// Generic sensor-axis candidates for any vector channel whose prediction is h (sensor frame).
void AddAxisCandidates(const std::vector<double>& t, const std::vector<Vec3>& h, const std::string& unit,
                       ChannelData* ch) {
  const size_t n = h.size();
  Candidate mis = MakeCandidate("misalignment", {"phi_x_deg", "phi_y_deg", "phi_z_deg"},
                                {kRadToDeg, kRadToDeg, kRadToDeg}, "deg");
  Candidate sc = MakeCandidate("scale_error", {"scale_minus_1"}, {1.0}, "1");
  Candidate lat = MakeCandidate("latency", {"latency_s"}, {1.0}, "s");
  const std::vector<Vec3> dh = Derivative(t, h);
  for (size_t k = 0; k < n; ++k) {
    mis.X.emplace_back(-Skew(h[k]));  // φ × h = −[h]×·φ
    sc.X.emplace_back(h[k]);
    lat.X.emplace_back(-dh[k]);  // h(t − L) ≈ h(t) − L·dh/dt
  }
  (void)unit;
  ch->candidates.push_back(std::move(mis));
  ch->candidates.push_back(std::move(sc));
  ch->candidates.push_back(std::move(lat));
}

namespace {

std::string MagPrefix(size_t c) { return c == 0 ? "mag" : fmt::format("mag{}", c + 1); }

void ReplayCompass(const logs::FlightLog& log, const vehicle::VehicleParams& v, size_t c, const LogInputs& in,
                   const Vec3& B_N_uT, ReplayResult* out) {
  const std::string pre = MagPrefix(c);
  const vehicle::CompassParams& cp = v.compasses[c];
  const auto& t_row = log.Column("t_s");
  const auto& mx = log.Column(pre + "_x_uT");
  const auto& my = log.Column(pre + "_y_uT");
  const auto& mz = log.Column(pre + "_z_uT");
  const std::vector<double>* mt = Col(log, pre + "_t_s");
  const size_t n_motor = v.rotors.size();

  magnetics::CurrentFieldParams wiring = v.wiring;
  if (cp.current_lag_tau_s >= 0) wiring.lag_tau_s = cp.current_lag_tau_s;

  ChannelData ch;
  ch.name = pre;
  ch.unit = "uT";
  ch.bias_nuisance = cp.noise.bias_std > 0 || cp.noise.bias_walk_per_sqrt_s > 0;

  // Sample selection: a new compass sample where its time stamp (or, without one, its value) changes.
  std::vector<double> ts;
  std::vector<Vec3> meas;
  std::vector<int> rows;
  double last_t = -1e300;
  Vec3 last_v(std::nan(""), std::nan(""), std::nan(""));
  for (size_t i = 0; i < log.rows(); ++i) {
    const Vec3 m(mx[i], my[i], mz[i]);
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
    ts.push_back(tm);
    meas.push_back(m);
    rows.push_back(static_cast<int>(i));
  }

  RowCursor cur{t_row};
  magnetics::CurrentLagState lag;
  double prev_t = 0;
  bool first = true;
  std::vector<Vec3> h;                       // predicted field before hard iron, sensor frame
  std::vector<Eigen::Matrix3d> Msens, Rt;    // R_SB·scale·K(I), R_NBᵀ
  std::vector<double> I, u, temp;
  std::vector<magnetics::Currents> currents;
  const bool has_current = in.current != nullptr;
  const bool has_throttle = in.control_u != nullptr || !in.motor_u.empty();
  for (size_t k = 0; k < ts.size(); ++k) {
    double w = 0;
    if (!cur.Seek(ts[k], &w)) continue;
    const size_t i = cur.i;
    const Eigen::Quaterniond q = QuatLerp(in.q, i, w);
    if (!q.coeffs().allFinite()) continue;
    magnetics::Currents cu;
    cu.battery_A = has_current ? Lerp(*in.current, i, w) : 0.0;
    cu.motor_A.assign(n_motor, 0.0);
    if (!in.motor_A.empty()) {
      for (size_t m = 0; m < n_motor; ++m) cu.motor_A[m] = Lerp(*in.motor_A[m], i, w);
    } else if (has_current) {
      const double each = std::max(0.0, cu.battery_A - v.avionics_current_A) / static_cast<double>(n_motor);
      std::fill(cu.motor_A.begin(), cu.motor_A.end(), each);
    }
    double thr = std::nan("");
    if (in.control_u) {
      thr = Lerp(*in.control_u, i, w) / kThrottleFullScale;
    } else if (!in.motor_u.empty()) {
      thr = 0;
      for (auto* mu : in.motor_u) thr += Lerp(*mu, i, w) / static_cast<double>(in.motor_u.size());
    }
    bool ok = std::isfinite(cu.battery_A);
    // Between two log rows the current is unknown; where it jumps (motor spin-up, touchdown) the
    // interpolated current cannot predict the wiring field, so such samples are left out.
    constexpr double kMaxCurrentStep_A = 2.0;
    if (has_current && w > 0 && std::fabs((*in.current)[i + 1] - (*in.current)[i]) > kMaxCurrentStep_A) continue;
    for (double a : cu.motor_A) ok = ok && std::isfinite(a);
    if (!ok) continue;
    const double dt = first ? 0.0 : std::max(0.0, ts[k] - prev_t);
    first = false;
    prev_t = ts[k];
    const magnetics::Currents& lagged = magnetics::StepCurrentLag(wiring, cu, dt, &lag);
    const Eigen::Matrix3d R_NB = q.toRotationMatrix();
    const Vec3 pred = magnetics::NoiselessCompassReading_uT(cp.error, wiring, cp.position_B_m, R_NB, B_N_uT, lagged);
    const Eigen::Matrix3d M = cp.error.R_SB * (cp.error.scale * (cp.error.soft_iron + lagged.battery_A * cp.error.soft_iron_per_A));
    ch.t.push_back(ts[k]);
    ch.y.emplace_back(meas[k] - pred);
    ch.row.push_back(rows[k]);
    h.emplace_back(pred - cp.error.hard_iron_uT);
    Msens.push_back(M);
    Rt.emplace_back(R_NB.transpose());
    I.push_back(cu.battery_A);
    u.push_back(thr);
    temp.push_back(in.temp ? Lerp(*in.temp, i, w) : std::nan(""));
    currents.push_back(cu);
  }
  const size_t n = ch.t.size();

  Candidate hi = MakeCandidate("hard_iron_offset", {"b_x_uT", "b_y_uT", "b_z_uT"}, {1, 1, 1}, "uT");
  Candidate an = MakeCandidate("local_anomaly", {"anomaly_N_uT", "anomaly_E_uT", "anomaly_D_uT"}, {1, 1, 1}, "uT");
  for (size_t k = 0; k < n; ++k) {
    hi.X.push_back(Diag3(1.0));
    an.X.emplace_back(Msens[k] * Rt[k]);
  }
  if (!ch.bias_nuisance) ch.candidates.push_back(std::move(hi));
  ch.candidates.push_back(std::move(an));
  AddAxisCandidates(ch.t, h, "uT", &ch);

  if (has_current) {
    Candidate chi = MakeCandidate("current_hard_iron", {"d_x_uT_per_A", "d_y_uT_per_A", "d_z_uT_per_A"}, {1, 1, 1},
                                  "uT/A", "current_A");
    Candidate csi = MakeCandidate("current_soft_iron",
                                  {"dK_xx_per_A", "dK_xy_per_A", "dK_xz_per_A", "dK_yx_per_A", "dK_yy_per_A",
                                   "dK_yz_per_A", "dK_zx_per_A", "dK_zy_per_A", "dK_zz_per_A"},
                                  std::vector<double>(9, 1.0), "1/A", "current_A");
    for (size_t k = 0; k < n; ++k) {
      chi.X.push_back(Diag3(I[k]));
      chi.regressor.push_back(I[k]);
      Mat3X x = Mat3X::Zero(3, 9);
      for (int r = 0; r < 3; ++r) {
        for (int j = 0; j < 3; ++j) x(r, 3 * r + j) = I[k] * h[k][j];  // r_i = Σ_j E_ij·I·h_j
      }
      csi.X.push_back(x);
      csi.regressor.push_back(I[k]);
    }
    ch.candidates.push_back(std::move(chi));
    ch.candidates.push_back(std::move(csi));

    // current_lag: the configured wiring field arrives through a first-order lag τ instead of the
    // configured one: r = a·M·(W(lp_τ(I)) − W(lp_τcfg(I))), a ≈ 1, τ profiled over a grid.
    double wiring_energy = 0;
    for (size_t k = 0; k < n; ++k) {
      wiring_energy += magnetics::CurrentDrivenField_uT(wiring, cp.position_B_m, currents[k]).squaredNorm();
    }
    if (n > 0 && std::sqrt(wiring_energy / static_cast<double>(n)) > 0.05) {
      for (double tau : kLagGrid_s) {
        if (tau <= wiring.lag_tau_s) continue;
        magnetics::CurrentFieldParams lagged_wiring = wiring;
        lagged_wiring.lag_tau_s = tau;
        magnetics::CurrentLagState s_new, s_cfg;
        Candidate cl = MakeCandidate("current_lag", {"amplitude"}, {1.0}, "s", "current_A");
        cl.grid_value = tau;
        cl.grid_name = "tau_s";
        for (size_t k = 0; k < n; ++k) {
          const double dt = k == 0 ? 0.0 : ch.t[k] - ch.t[k - 1];
          const Vec3 a = magnetics::CurrentDrivenField_uT(
              wiring, cp.position_B_m, magnetics::StepCurrentLag(lagged_wiring, currents[k], dt, &s_new));
          const Vec3 b = magnetics::CurrentDrivenField_uT(
              wiring, cp.position_B_m, magnetics::StepCurrentLag(wiring, currents[k], dt, &s_cfg));
          cl.X.emplace_back(Msens[k] * (a - b));
          cl.regressor.push_back(I[k]);
        }
        ch.candidates.push_back(std::move(cl));
      }
    } else {
      ch.not_available.emplace_back("current_lag (configured wiring field at this compass too small to show a lag)");
    }
  } else {
    ch.not_available.emplace_back("current_hard_iron, current_soft_iron, current_lag (no current_A column)");
  }
  bool throttle_ok = has_throttle && n > 0;
  for (double x : u) throttle_ok = throttle_ok && std::isfinite(x);
  if (throttle_ok) {
    Candidate thi = MakeCandidate("throttle_hard_iron", {"d_x_uT_per_throttle", "d_y_uT_per_throttle",
                                                         "d_z_uT_per_throttle"},
                                  {1, 1, 1}, "uT/throttle", "throttle");
    for (size_t k = 0; k < n; ++k) {
      thi.X.push_back(Diag3(u[k]));
      thi.regressor.push_back(u[k]);
    }
    ch.candidates.push_back(std::move(thi));
  } else {
    ch.not_available.emplace_back("throttle_hard_iron (no control_u or motor_i_u)");
  }
  bool temp_ok = in.temp != nullptr && n > 0;
  double tmean = 0;
  for (double x : temp) {
    temp_ok = temp_ok && std::isfinite(x);
    tmean += x;
  }
  if (temp_ok) {
    tmean /= static_cast<double>(n);
    double tvar = 0;
    for (double x : temp) tvar += (x - tmean) * (x - tmean);
    temp_ok = tvar / static_cast<double>(n) > 0.01;  // needs > 0.1 °C of variation
  }
  if (temp_ok) {
    // B = d·(T − T_ref), T_ref the board temperature at the start of the log (the sensor is taken as
    // calibrated where the flight starts). No offset term: a constant field error is the separate
    // hard_iron_offset candidate, so a drift cannot absorb the calibration's hard iron; where both
    // are present the forward step selects the pair.
    // T_ref: the median of the first 10 samples (a fraction of a second: robust to the temperature
    // sensor's noise, short against the warm-up).
    std::vector<double> first(temp.begin(), temp.begin() + static_cast<std::ptrdiff_t>(std::min<size_t>(10, n)));
    std::nth_element(first.begin(), first.begin() + static_cast<std::ptrdiff_t>(first.size() / 2), first.end());
    const double tref = first[first.size() / 2];
    Candidate td = MakeCandidate("temperature_drift", {"d_x_uT_per_C", "d_y_uT_per_C", "d_z_uT_per_C"}, {1, 1, 1},
                                 "uT/C", "imu_temp_C");
    for (size_t k = 0; k < n; ++k) {
      td.X.push_back(Diag3(temp[k] - tref));
      td.regressor.push_back(temp[k]);
    }
    ch.candidates.push_back(std::move(td));
  } else {
    ch.not_available.emplace_back("temperature_drift (no imu_temp_C column with varying temperature)");
  }
  out->channels.push_back(std::move(ch));
}

// Gyro and accelerometer from the attitude and velocity derivatives (rows).
void ReplayInertial(const logs::FlightLog& log, const vehicle::VehicleParams& v, const LogInputs& in,
                    ReplayResult* out) {
  const auto& t = log.Column("t_s");
  const size_t n = log.rows();
  const bool has_gyro = ColumnHasData(log, "gyro_x_radps") && ColumnHasData(log, "gyro_y_radps") &&
                        ColumnHasData(log, "gyro_z_radps");
  const bool has_accel = ColumnHasData(log, "accel_x_mps2") && ColumnHasData(log, "accel_y_mps2") &&
                         ColumnHasData(log, "accel_z_mps2");
  const bool has_vel = ColumnHasData(log, "vel_N_mps") && ColumnHasData(log, "vel_E_mps") &&
                       ColumnHasData(log, "vel_D_mps");
  constexpr double kMaxRowGap_s = 0.1;  // derivatives need rows at least this dense
  // Native-rate streams where the log has them (inertial_streams.cc); rows otherwise.
  const bool gyro_native = ReplayGyroStream(log, v, out);
  const bool accel_native = ReplayAccelStream(log, v, out);
  if (gyro_native && accel_native) return;
  if (!has_gyro) out->not_diagnosed.emplace_back("gyro", "no gyro_*_radps columns");
  if (!has_accel) out->not_diagnosed.emplace_back("accel", "no accel_*_mps2 columns");
  else if (!has_vel) out->not_diagnosed.emplace_back("accel", "no vel_*_mps columns to differentiate");
  for (int which = 0; which < 2; ++which) {
    if (which == 0 && (gyro_native || !has_gyro)) continue;
    if (which == 1 && (accel_native || !has_accel || !has_vel)) continue;
    ChannelData ch;
    ch.name = which == 0 ? "gyro" : "accel";
    ch.unit = which == 0 ? "rad/s" : "m/s^2";
    const vehicle::NoiseParams& np = which == 0 ? v.sensors.gyro.noise : v.sensors.accel.noise;
    ch.bias_nuisance = np.bias_std > 0 || np.bias_walk_per_sqrt_s > 0;
    const std::string pre = ch.name + "_";
    const std::string unit = which == 0 ? "_radps" : "_mps2";
    const auto& sx = log.Column(fmt::format("{}x{}", pre, unit));
    const auto& sy = log.Column(fmt::format("{}y{}", pre, unit));
    const auto& sz = log.Column(fmt::format("{}z{}", pre, unit));
    std::vector<Vec3> h;
    for (size_t k = 1; k + 1 < n; ++k) {
      const double dt = t[k + 1] - t[k - 1];
      if (!(dt > 0) || dt > 2 * kMaxRowGap_s) continue;
      const Vec3 m(sx[k], sy[k], sz[k]);
      if (!m.allFinite()) continue;
      const Eigen::Quaterniond qa = QuatRow(in.q, k - 1).normalized(), qb = QuatRow(in.q, k + 1).normalized();
      const Eigen::Quaterniond qk = QuatRow(in.q, k).normalized();
      if (!qa.coeffs().allFinite() || !qb.coeffs().allFinite() || !qk.coeffs().allFinite()) continue;
      Vec3 pred;
      if (which == 0) {
        pred = QuatLog(qa.conjugate() * qb) / dt;  // body rate: q_b = q_a ⊗ exp(w·dt)
      } else {
        const auto& vn = log.Column("vel_N_mps");
        const auto& ve = log.Column("vel_E_mps");
        const auto& vd = log.Column("vel_D_mps");
        const Vec3 a_N((vn[k + 1] - vn[k - 1]) / dt, (ve[k + 1] - ve[k - 1]) / dt, (vd[k + 1] - vd[k - 1]) / dt);
        if (!a_N.allFinite()) continue;
        pred = qk.toRotationMatrix().transpose() * (a_N - Vec3(0, 0, kGravity_mps2));  // f_B = R_NBᵀ(a − g)
      }
      ch.t.push_back(t[k]);
      ch.y.emplace_back(m - pred);
      ch.row.push_back(static_cast<int>(k));
      h.push_back(pred);
    }
    // The known sample hold: the row carries the latest IMU sample, taken up to one IMU period
    // before the row (no per-sample time stamp in the log), and the attitude difference is centred
    // on the row. Fit the latency, keep the part inside [0, period] as configured behaviour.
    const double rate_hz = which == 0 ? v.sensors.gyro.rate_hz : v.sensors.accel.rate_hz;
    if (rate_hz > 0 && ch.t.size() > 10) {
      const std::vector<Vec3> dh = Derivative(ch.t, h);
      Vec3 my = Vec3::Zero(), md = Vec3::Zero();
      if (ch.bias_nuisance) {
        for (size_t k = 0; k < ch.t.size(); ++k) {
          my += ch.y[k];
          md += dh[k];
        }
        my /= static_cast<double>(ch.t.size());
        md /= static_cast<double>(ch.t.size());
      }
      double num = 0, den = 0;
      for (size_t k = 0; k < ch.t.size(); ++k) {
        num += (dh[k] - md).dot(ch.y[k] - my);
        den += (dh[k] - md).squaredNorm();
      }
      ch.known_hold_max_s = 1.0 / rate_hz;
      ch.known_hold_s = den > 0 ? std::clamp(-num / den, 0.0, ch.known_hold_max_s) : 0.0;
      for (size_t k = 0; k < ch.t.size(); ++k) ch.y[k] += dh[k] * ch.known_hold_s;  // y − (−dh)·L0
    }
    if (!ch.bias_nuisance) {
      Candidate off = MakeCandidate("bias", {"b_x", "b_y", "b_z"}, {1, 1, 1}, ch.unit);
      for (size_t k = 0; k < ch.t.size(); ++k) off.X.push_back(Diag3(1.0));
      ch.candidates.push_back(std::move(off));
    }
    AddAxisCandidates(ch.t, h, ch.unit, &ch);
    if (which == 1) {
      ch.not_available.emplace_back("rotor_drag, ground_effect, battery_sag, motor_time_constant, wind: see the "
                                    "'dynamics' channel (specific force predicted from the motor outputs)");
    }
    out->channels.push_back(std::move(ch));
  }
}

}  // namespace

ReplayResult Replay(const logs::FlightLog& log, const vehicle::VehicleParams& v, const DiagnoseOptions& options) {
  ReplayResult out;
  LogInputs in;
  const char* qn[4] = {"q_w", "q_x", "q_y", "q_z"};
  in.has_attitude = true;
  for (const char* c : qn) {
    if (!ColumnHasData(log, c)) in.has_attitude = false;
  }
  const bool sim_truth = log.meta.value("source", std::string()) == "hexsim";
  out.attitude_source = sim_truth ? "simulator truth (q_*)"
                                  : "q_* from the log: " + log.meta.value("attitude_source", std::string("the autopilot's estimate"));
  if (options.contaminating_compass == "auto") {
    if (!sim_truth && in.has_attitude) {
      // The autopilot's EKF fuses its primary compass (COMPASS_PRIMARY, default the first).
      int primary = 0;
      if (log.meta.contains("params") && log.meta["params"].is_object() && log.meta["params"].contains("COMPASS_PRIMARY") &&
          log.meta["params"]["COMPASS_PRIMARY"].is_number()) {
        primary = log.meta["params"]["COMPASS_PRIMARY"].get<int>();
      }
      out.contaminated = MagPrefix(static_cast<size_t>(std::max(0, primary)));
    }
  } else {
    out.contaminated = options.contaminating_compass;
  }
  // Compass columns in the log.
  std::vector<size_t> log_compasses;
  for (size_t c = 0; c < 8; ++c) {
    if (ColumnHasData(log, MagPrefix(c) + "_x_uT")) log_compasses.push_back(c);
  }
  if (!in.has_attitude) {
    for (size_t c : log_compasses) out.not_diagnosed.emplace_back(MagPrefix(c), "no attitude (q_w..q_z): the compass cannot be predicted");
    out.not_diagnosed.emplace_back("gyro", "no attitude (q_w..q_z) to differentiate");
    out.not_diagnosed.emplace_back("accel", "no attitude (q_w..q_z) to rotate the acceleration");
    out.not_diagnosed.emplace_back("dynamics", "no attitude (q_w..q_z) to rotate the velocity and the thrust");
    if (log_compasses.empty()) out.not_diagnosed.emplace_back("mag", "no compass columns (mag_x_uT ...)");
    return out;
  }
  for (const char* c : qn) in.q.push_back(&log.Column(c));
  if (ColumnHasData(log, "current_A")) in.current = &log.Column("current_A");
  if (ColumnHasData(log, "control_u")) in.control_u = &log.Column("control_u");
  if (ColumnHasData(log, "imu_temp_C")) in.temp = &log.Column("imu_temp_C");
  bool all_motor_A = !v.rotors.empty();
  bool all_motor_u = !v.rotors.empty();
  for (size_t m = 0; m < v.rotors.size(); ++m) {
    all_motor_A = all_motor_A && ColumnHasData(log, fmt::format("motor_{}_A", m + 1));
    all_motor_u = all_motor_u && ColumnHasData(log, fmt::format("motor_{}_u", m + 1));
  }
  for (size_t m = 0; all_motor_A && m < v.rotors.size(); ++m) in.motor_A.push_back(&log.Column(fmt::format("motor_{}_A", m + 1)));
  for (size_t m = 0; all_motor_u && m < v.rotors.size(); ++m) in.motor_u.push_back(&log.Column(fmt::format("motor_{}_u", m + 1)));

  if (log_compasses.empty()) {
    out.not_diagnosed.emplace_back("mag", "no compass columns (mag_x_uT ...)");
  } else {
    // Earth field at the log's place and date.
    const auto& meta = log.meta;
    bool have_place = meta.contains("location") && meta["location"].is_object() && meta["location"].contains("lat_deg") &&
                      meta["location"].contains("lon_deg") && meta.contains("date_decimal_year") &&
                      meta["date_decimal_year"].is_number();
    Result<magnetics::EarthField> field = Status::BadInput("no location/date");
    if (have_place) {
      magnetics::GeodeticPoint where;
      where.lat_deg = meta["location"]["lat_deg"].get<double>();
      where.lon_deg = meta["location"]["lon_deg"].get<double>();
      where.alt_m = meta["location"].contains("alt_m") && meta["location"]["alt_m"].is_number()
                        ? meta["location"]["alt_m"].get<double>()
                        : 0.0;
      field = magnetics::EvaluateWmm(where, meta["date_decimal_year"].get<double>(), options.allow_field_extrapolation);
    }
    if (!field.ok()) {
      for (size_t c : log_compasses) {
        out.not_diagnosed.emplace_back(MagPrefix(c), "no usable location/date_decimal_year in the meta file for the field model (" +
                                                         field.status().message() + ")");
      }
    } else {
      out.field_model = field->model;
      out.earth_field_N_uT = field->B_N_uT;
      for (size_t c : log_compasses) {
        if (c >= v.compasses.size()) {
          out.not_diagnosed.emplace_back(MagPrefix(c), fmt::format("the vehicle '{}' configures no compass {}", v.name, c + 1));
          continue;
        }
        ReplayCompass(log, v, c, in, field->B_N_uT, &out);
      }
    }
  }
  ReplayInertial(log, v, in, &out);
  ReplayDynamics(log, v, options, &out);
  return out;
}

}  // namespace hexsim::gap::internal
