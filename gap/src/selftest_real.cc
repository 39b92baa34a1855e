// The selftest's real profile (issue 16 item 8): a simulated trial log made as hard as a real one.
//   - compass, attitude and current at 10 Hz (rows decimated; each compass keeps its own stamps);
//   - the reference attitude of an estimator that fused the first compass: its yaw error is the
//     calibrated first compass's heading error through a 10 s first-order filter (a complementary
//     filter's yaw loop);
//   - each compass latency L ~ U[20, 100] ms against the attitude, a residual calibration offset
//     |b| ~ U[0, 4] µT and a field-norm error s ~ U[−3, 3] % (inside their normal ranges);
//   - the battery current S ~ U[100, 300] ms stale, updated at 5 Hz (half its 10 Hz samples repeat),
//     no per-motor currents;
//   - out of library (class out_of_library): one family per trial, drawn at random.
#include "selftest_real.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <fmt/format.h>

#include "hexsim/common/rotation.h"

namespace hexsim::gap::internal {
Vec3 RandomUnit(RngStream* rng) {
  Vec3 v = rng->Normal3(1.0);
  return v / std::max(1e-12, v.norm());
}

namespace {

// Index of the last row at or before tq (rows ascending).
size_t RowAt(const std::vector<double>& t, double tq) {
  const auto it = std::upper_bound(t.begin(), t.end(), tq);
  return it == t.begin() ? 0 : static_cast<size_t>(it - t.begin()) - 1;
}

std::string Prefix(size_t c) { return c == 0 ? "mag" : fmt::format("mag{}", c + 1); }

}  // namespace

const std::vector<LogForm>& OutOfLibraryFamilies() {
  // A static per-axis scale is in the library now (scale_error's per-axis family), not out of it.
  static const std::vector<LogForm> kFamilies = {{"current_power", {}},  {"current_saturation", {}}, {"offset_drift", {}},
                                                 {"cross_coupling", {}}, {"periodic", {}},           {"spikes", {}},
                                                 {"regime_current", {}}};
  return kFamilies;
}

Status InjectOutOfLibrary(logs::FlightLog* log, size_t compass, const std::string& family, RngStream* rng) {
  const std::string pre = Prefix(compass);
  if (!log->Has(pre + "_x_uT") || !log->Has("current_A") || !log->Has("control_u")) {
    return Status::BadInput("selftest: the trial log lacks " + pre + ", current_A or control_u");
  }
  const size_t cx = static_cast<size_t>(log->ColumnIndex(pre + "_x_uT"));
  const auto& t = log->Column("t_s");
  const auto& I = log->Column("current_A");
  const auto& u = log->Column("control_u");
  const size_t n = log->rows();
  const Vec3 d = RandomUnit(rng);
  const double a = 3.0 + 3.0 * rng->Uniform();  // µT: far above the 0.3 µT noise
  const double p = 1.8 + 0.7 * rng->Uniform();
  const double i_sat = 3.0 + 3.0 * rng->Uniform();
  const double s = 0.06 + 0.06 * rng->Uniform();
  const int ax = static_cast<int>(rng->Uniform() * 3) % 3, bx = (ax + 1) % 3;
  const double f_hz = 0.05 + 0.45 * rng->Uniform(), phase = 6.283185307179586 * rng->Uniform();
  const double k_regime = 0.4 + 0.4 * rng->Uniform();
  std::vector<double> sorted_u;
  for (double v : u) {
    if (std::isfinite(v)) sorted_u.push_back(v);
  }
  std::sort(sorted_u.begin(), sorted_u.end());
  const double u_med = sorted_u.empty() ? 0.0 : sorted_u[sorted_u.size() / 2];
  const double t0 = t.front(), span = std::max(1.0, t.back() - t.front());
  for (size_t i = 0; i < n; ++i) {
    Vec3 m(log->At(i, cx), log->At(i, cx + 1), log->At(i, cx + 2));
    if (!m.allFinite()) continue;
    const double Ii = std::isfinite(I[i]) ? std::max(0.0, I[i]) : 0.0;
    if (family == "current_power") m += d * a * std::pow(Ii / 10.0, p);
    else if (family == "current_saturation") m += d * a * std::tanh(Ii / i_sat);
    else if (family == "offset_drift") m += d * a * (t[i] - t0) / span;
    else if (family == "axis_scale") m[ax] *= 1.0 + s;
    else if (family == "cross_coupling") m[ax] += s * m[bx];
    else if (family == "periodic") m += d * a * std::sin(6.283185307179586 * f_hz * t[i] + phase);
    else if (family == "spikes") {
      if (rng->Uniform() < 0.02) {
        // One draw per statement: the operands of * are unsequenced, and gcc and clang order them
        // differently (the trials must not depend on the compiler).
        const double sign = rng->Uniform() < 0.5 ? -1.0 : 1.0;
        m[ax] += sign * (10.0 + 20.0 * rng->Uniform());
      }
    } else if (family == "regime_current") {
      if (u[i] > u_med) m += d * k_regime * Ii;
    } else {
      return Status::BadInput("selftest: unknown out-of-library family '" + family + "'");
    }
    for (int k = 0; k < 3; ++k) log->MutableColumn(cx + static_cast<size_t>(k))[i] = m[k];
  }
  return Status::Ok();
}

Result<logs::FlightLog> DegradeToRealLog(const logs::FlightLog& in, const vehicle::VehicleParams& configured,
                                         RngStream* rng, RealLogTruth* truth) {
  logs::FlightLog log = in;
  const auto& t = in.Column("t_s");
  const size_t n = in.rows();
  if (n < 10 || !in.Has("q_w")) return Status::BadInput("selftest: the trial log has no attitude");
  // Reference attitude: q' = q_z(e) ⊗ q, e the filtered heading error of the calibrated first compass.
  if (!configured.compasses.empty() && in.Has("mag_x_uT")) {
    const auto& ce = configured.compasses[0].error;
    const Eigen::Matrix3d Minv = (ce.R_SB * ce.scale * ce.soft_iron).inverse();
    std::vector<double> err(n, 0.0);
    double mean_s = 0, mean_c = 0;
    for (size_t i = 0; i < n; ++i) {
      const Eigen::Quaterniond q(in.Column("q_w")[i], in.Column("q_x")[i], in.Column("q_y")[i], in.Column("q_z")[i]);
      const Vec3 m(in.Column("mag_x_uT")[i], in.Column("mag_y_uT")[i], in.Column("mag_z_uT")[i]);
      if (!m.allFinite()) continue;
      const Vec3 mN = q.normalized().toRotationMatrix() * (Minv * (m - ce.hard_iron_uT));
      err[i] = std::atan2(mN.y(), mN.x());
      mean_s += std::sin(err[i]);
      mean_c += std::cos(err[i]);
    }
    const double psi0 = std::atan2(mean_s, mean_c);
    constexpr double kYawLoop_s = 10.0;
    double e = 0;
    for (size_t i = 0; i < n; ++i) {
      const double dt = i > 0 ? t[i] - t[i - 1] : 0.0;
      const double raw = std::remainder(err[i] - psi0, 6.283185307179586);
      e += (raw - e) * std::min(1.0, dt / kYawLoop_s);
      const Eigen::Quaterniond q(in.Column("q_w")[i], in.Column("q_x")[i], in.Column("q_y")[i], in.Column("q_z")[i]);
      const Eigen::Quaterniond qr = Eigen::Quaterniond(Eigen::AngleAxisd(e, Vec3::UnitZ())) * q;
      log.MutableColumn(static_cast<size_t>(log.ColumnIndex("q_w")))[i] = qr.w();
      log.MutableColumn(static_cast<size_t>(log.ColumnIndex("q_x")))[i] = qr.x();
      log.MutableColumn(static_cast<size_t>(log.ColumnIndex("q_y")))[i] = qr.y();
      log.MutableColumn(static_cast<size_t>(log.ColumnIndex("q_z")))[i] = qr.z();
    }
  }
  // Compasses: latency, offset, field-norm error.
  truth->latency_s = 0.02 + 0.08 * rng->Uniform();
  for (size_t c = 0; c < 8; ++c) {
    const std::string pre = Prefix(c);
    if (!in.Has(pre + "_x_uT")) continue;
    const Vec3 dir = RandomUnit(rng);  // before the size: one draw per statement (see above)
    const Vec3 b = dir * 4.0 * rng->Uniform();
    const double s = -0.03 + 0.06 * rng->Uniform();
    if (c == 1) {
      truth->offset_uT = b;
      truth->scale = s;
    }
    const size_t cx = static_cast<size_t>(log.ColumnIndex(pre + "_x_uT"));
    // A sample measured at τ is logged with the stamp τ + L: each row carries the newest sample
    // whose delayed stamp has passed, with that stamp (exactly L late, as a real driver's queue;
    // taking the row value at t − L instead would mix sample-and-hold jitter of a sensor period
    // into the latency, a timing noise real logs do not have).
    const std::vector<double>* mt = in.Has(pre + "_t_s") ? &in.Column(pre + "_t_s") : nullptr;
    const size_t ct = mt ? static_cast<size_t>(log.ColumnIndex(pre + "_t_s")) : 0;
    size_t j = 0;  // newest input row whose sample is due
    for (size_t i = 0; i < n; ++i) {
      if (mt) {
        while (j + 1 < n && std::isfinite((*mt)[j + 1]) && (*mt)[j + 1] + truth->latency_s <= t[i]) ++j;
      } else {
        j = RowAt(t, t[i] - truth->latency_s);
      }
      const Vec3 m(in.At(j, cx), in.At(j, cx + 1), in.At(j, cx + 2));
      for (int k = 0; k < 3; ++k) log.MutableColumn(cx + static_cast<size_t>(k))[i] = (1.0 + s) * m[k] + b[k];
      if (mt) log.MutableColumn(ct)[i] = (*mt)[j] + truth->latency_s;
    }
  }
  // Current: stale and updated at 5 Hz; per-motor currents are not logged by real autopilots.
  truth->staleness_s = 0.1 + 0.2 * rng->Uniform();
  if (in.Has("current_A")) {
    const size_t ci = static_cast<size_t>(log.ColumnIndex("current_A"));
    const size_t ct = log.AddColumn("batt_t_s");
    constexpr double kUpdate_s = 0.2;
    for (size_t i = 0; i < n; ++i) {
      const double upd = std::floor(t[i] / kUpdate_s) * kUpdate_s;
      log.MutableColumn(ci)[i] = in.Column("current_A")[RowAt(t, upd - truth->staleness_s)];
      log.MutableColumn(ct)[i] = upd;
    }
  }
  for (size_t m = 1; m <= 16; ++m) {
    const std::string col = fmt::format("motor_{}_A", m);
    if (!log.Has(col)) continue;
    auto& v = log.MutableColumn(static_cast<size_t>(log.ColumnIndex(col)));
    std::fill(v.begin(), v.end(), logs::kMissing);
  }
  // Rows at 10 Hz.
  logs::FlightLog out;
  out.meta = log.meta;
  for (const auto& name : log.columns()) out.AddColumn(name);
  constexpr double kRowRate_hz = 10.0;
  double next = t.front();
  for (size_t i = 0; i < n; ++i) {
    if (t[i] + 1e-9 < next) continue;
    next = t[i] + 1.0 / kRowRate_hz;
    out.AppendRow();
    for (size_t c = 0; c < log.columns().size(); ++c) out.Set(c, log.At(i, c));
  }
  return out;
}

}  // namespace hexsim::gap::internal
