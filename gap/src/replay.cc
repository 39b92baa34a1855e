// Replay: drive the configured models with what the log says happened and build the residuals and
// the candidate effects' regressors per channel.
#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <fmt/format.h>

#include "channels.h"
#include "replay_util.h"
#include "hexsim/common/rotation.h"
#include "hexsim/logs/current_check.h"
#include "hexsim/magnetics/compass_model.h"
#include "hexsim/magnetics/wmm.h"
#include "hexsim/realdata/timing.h"

namespace hexsim::gap::internal {

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

// The attitude difference between rows k−1 and k+1 gives the mean body rate over that interval;
// the gyro samples the rate at an instant. For a rate that is smooth on the row scale, the mean
// over an interval of width W centred at c is w(c) + w''·W²/24, a bias that grows with the
// curvature of the rate: at a manoeuvre's peak rate it reads low, so it shows as a rate-correlated
// "scale" error of a few 1e-3 (measured on simulated square missions, where the logged attitude is
// the truth). Here w'' is taken from the neighbouring interval means (second divided difference on
// their centres) where the rows on both sides were kept, and the prediction h and residual y are
// moved to the instantaneous rate: h −= w''·W²/24, y += w''·W²/24.
void InstantaneousFromIntervalMeans(const std::vector<double>& t, ChannelData* ch, std::vector<Vec3>* h) {
  const size_t n = h->size();
  if (n < 3) return;
  const std::vector<Vec3> mean = *h;
  // Sample k's interval is rows row[k] − 1 .. row[k] + 1 (row[k] ≥ 1 for every kept sample).
  auto first = [&](size_t k) { return static_cast<size_t>(ch->row[k]) - 1; };
  auto centre = [&](size_t k) { return 0.5 * (t[first(k)] + t[first(k) + 2]); };
  for (size_t k = 1; k + 1 < n; ++k) {
    if (ch->row[k - 1] != ch->row[k] - 1 || ch->row[k + 1] != ch->row[k] + 1) continue;
    const double c0 = centre(k - 1), c1 = centre(k), c2 = centre(k + 1);
    if (!(c1 > c0) || !(c2 > c1)) continue;
    const Vec3 w2 = 2.0 * ((mean[k + 1] - mean[k]) / (c2 - c1) - (mean[k] - mean[k - 1]) / (c1 - c0)) / (c2 - c0);
    const double W = t[first(k) + 2] - t[first(k)];
    const Vec3 bias = w2 * (W * W / 24.0);
    (*h)[k] -= bias;
    ch->y[k] += bias;
  }
}

// Gyro and accelerometer from the attitude and velocity derivatives (rows).
void ReplayInertial(const logs::FlightLog& log, const vehicle::VehicleParams& v, const LogInputs& in,
                    const std::vector<realdata::RowKind>& row_kind, ReplayResult* out) {
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
  const bool gyro_native = ReplayGyroStream(log, v, row_kind, out);
  const bool accel_native = ReplayAccelStream(log, v, row_kind, out);
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
      if (!(dt > 0) || dt > 2 * kMaxRowGap_s || row_kind[k] != realdata::RowKind::kFlight) continue;
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
    if (which == 0) InstantaneousFromIntervalMeans(t, &ch, &h);
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

ReplayResult Replay(const logs::FlightLog& log, const vehicle::VehicleParams& v, const DiagnoseOptions& options,
                    const std::vector<realdata::RowKind>& row_kind) {
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
  const logs::CurrentSensorCheck current_check = logs::CurrentSensorOf(log);
  in.current_usable = current_check.usable;
  if (ColumnHasData(log, "current_A") && !current_check.usable) in.current_unusable_why = current_check.why;
  if (ColumnHasData(log, "current_A") && current_check.usable) {
    static const std::vector<double> kNoStamps;
    const realdata::HeldSamples held = realdata::FirstAppearances(
        log.Column("t_s"), log.Has("batt_t_s") ? log.Column("batt_t_s") : kNoStamps, log.Column("current_A"));
    std::vector<double> rows = realdata::InterpolateSamples(held, log.Column("t_s"));
    const auto& raw = log.Column("current_A");
    for (size_t i = 0; i < rows.size(); ++i) rows[i] = std::isfinite(raw[i]) ? rows[i] : raw[i];
    in.current_rows = std::make_shared<const std::vector<double>>(std::move(rows));
    in.current_samples_t = held.t;
    in.current_samples_v = held.v;
    in.current = in.current_rows.get();
  }
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
      // No GPS fix: the Earth field is fitted per compass (diagnose.cc), as calibrate --method flight does.
      out.field_free = true;
      out.field_free_why = "no usable location/date_decimal_year in the meta file (" + field.status().message() + ")";
      out.field_model = "none: Earth field fitted freely per compass (" + out.field_free_why + ")";
    } else {
      out.field_model = field->model;
      out.earth_field_N_uT = field->B_N_uT;
    }
    for (size_t c : log_compasses) {
      if (c >= v.compasses.size()) {
        out.not_diagnosed.emplace_back(MagPrefix(c), fmt::format("the vehicle '{}' configures no compass {}", v.name, c + 1));
        continue;
      }
      out.compasses.push_back(c);
    }
  }
  const auto wanted = [&](const std::string& name) {
    return options.channels.empty() ||
           std::find(options.channels.begin(), options.channels.end(), name) != options.channels.end();
  };
  out.compasses.erase(std::remove_if(out.compasses.begin(), out.compasses.end(),
                                     [&](size_t c) { return !wanted(MagPrefix(c)); }),
                      out.compasses.end());
  if (wanted("gyro") || wanted("accel")) {
    ReplayInertial(log, v, in, row_kind, &out);
    out.channels.erase(std::remove_if(out.channels.begin(), out.channels.end(),
                                      [&](const ChannelData& ch) { return !wanted(ch.name); }),
                       out.channels.end());
  }
  if (wanted("dynamics")) ReplayDynamics(log, v, in, row_kind, &out);
  out.not_diagnosed.erase(std::remove_if(out.not_diagnosed.begin(), out.not_diagnosed.end(),
                                         [&](const auto& nd) { return !wanted(nd.first); }),
                          out.not_diagnosed.end());
  out.inputs = in;
  return out;
}

}  // namespace hexsim::gap::internal
