#include "samples.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "hexsim/common/plausibility.h"
#include "hexsim/logs/current_check.h"
#include "hexsim/realdata/velocity_check.h"
#include "hexsim/realdata/windows.h"

namespace hexsim::identify::internal {
namespace {

constexpr double kMinFlightOutput = 0.05;  // every motor above this output: turning, not idling on the ground
constexpr double kMinWindow_s = 2.0;       // shorter flight windows (after trimming) are left out
constexpr double kCommandGapReset_s = 0.5; // the motor-lag filter restarts after a longer RCOU gap
constexpr double kImuGapFactor = 3.0;      // consecutive IMU samples further apart are not differenced
// The EKF's height fuses the barometer (and GPS): the two stay within the barometer's drift over a
// flight (weather, temperature, prop wash: a few metres) and GPS's vertical error (under ~10 m). Their
// difference spreading wider than this means the EKF's height diverged (a failing sensor, a filter
// reset): the barometer's height is used instead.
constexpr double kMaxEkfBaroSpread_m = 20.0;

double Median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

double MedianRate_hz(const std::vector<double>& t) {
  std::vector<double> d;
  for (size_t i = 1; i < t.size(); ++i) d.push_back(t[i] - t[i - 1]);
  const double m = Median(d);
  return m > 0 ? 1.0 / m : 0.0;
}

// Latest sample index at or before t (advancing *i); false before the first sample.
bool Held(const std::vector<double>& t, double tq, size_t* i) {
  while (*i + 1 < t.size() && t[*i + 1] <= tq) ++*i;
  return !t.empty() && t[*i] <= tq;
}

const std::vector<double>* Col(const logs::FlightLog& s, const std::string& name) {
  return s.Has(name) ? &s.Column(name) : nullptr;
}

// The height the flight windows use: the EKF's (pos_D_m, down) where it follows the barometer, else
// baro_alt_m (up), with a note saying why. *up: +1 for an up-positive column, -1 for pos_D_m.
const std::vector<double>* HeightColumn(const logs::FlightLog& log, double* up, std::vector<std::string>* notes) {
  const std::vector<double>* pos_d = Col(log, "pos_D_m");
  const std::vector<double>* baro = Col(log, "baro_alt_m");
  *up = pos_d ? -1.0 : 1.0;
  if (!pos_d || !baro) return pos_d ? pos_d : baro;
  std::vector<double> diff;  // EKF height minus barometric height
  for (size_t r = 0; r < pos_d->size(); ++r) {
    if (std::isfinite((*pos_d)[r]) && std::isfinite((*baro)[r])) diff.push_back(-(*pos_d)[r] - (*baro)[r]);
  }
  if (diff.size() < 2) return pos_d;
  std::sort(diff.begin(), diff.end());
  const double spread = diff[diff.size() * 99 / 100] - diff[diff.size() / 100];  // 1st to 99th percentile
  if (spread <= kMaxEkfBaroSpread_m) return pos_d;
  notes->push_back(fmt::format("the EKF's height (pos_D_m) departs from the barometer's by {:.0f} m within the log "
                               "(more than {:.0f} m: the EKF diverged): flight windows use baro_alt_m",
                               spread, kMaxEkfBaroSpread_m));
  *up = 1.0;
  return baro;
}

// Maps a time inside the flight windows to its block: blocks split the flight time evenly.
struct BlockMap {
  std::vector<FlightWindow> w;
  double total_s = 0.0;
  int blocks = 1;
  int At(double t) const {
    double before = 0.0;
    for (const auto& x : w) {
      if (t >= x.start_s && t <= x.end_s) {
        const int b = static_cast<int>((before + t - x.start_s) / total_s * blocks);
        return std::clamp(b, 0, blocks - 1);
      }
      before += x.end_s - x.start_s;
    }
    return -1;
  }
  // The time spans of every block (a block may straddle two windows).
  std::vector<BlockSpan> Spans() const {
    std::vector<BlockSpan> out;
    double before = 0.0;
    for (const auto& x : w) {
      const double len = x.end_s - x.start_s;
      for (int b = 0; b < blocks; ++b) {
        const double b0 = total_s * b / blocks - before, b1 = total_s * (b + 1) / blocks - before;
        const double s0 = std::max(0.0, b0), s1 = std::min(len, b1);
        if (s1 > s0) out.push_back({x.start_s + s0, x.start_s + s1, b});
      }
      before += len;
    }
    return out;
  }
};

// The flight windows (realdata's, further restricted to every motor turning clear of the ground and
// armed where the log says) and the ground spans between them, written to out->windows; the blocks
// split the flight time evenly.
Result<BlockMap> FlightBlocks(const logs::FlightLog& log, const std::vector<double>& tr,
                              const std::vector<const std::vector<double>*>& mu, const std::vector<double>& alt,
                              double up, const IdentifyOptions& options, const std::string& name, FlightSamples* out) {
  const size_t n = mu.size();
  const auto& t_row = log.Column("t_s");
  const std::vector<double>* armed = Col(log, "armed");
  double h0 = std::nan("");
  for (double a : alt) {
    if (std::isfinite(a)) {
      h0 = up * a;
      break;
    }
  }
  // realdata's flight windows (armed, throttle above idle, attitude sane, before any flip or
  // crash), further restricted to every motor turning clear of the ground.
  const realdata::FlightWindows rw = realdata::FindFlightWindows(log);
  const double cut_s = std::isfinite(rw.cut_at_s) ? rw.cut_at_s : INFINITY;
  const realdata::VelocityCheck vcheck = realdata::CheckVelocityAgainstAccel(log, rw.row_kind);
  out->velocity_ok = vcheck.ok;
  out->velocity_why = vcheck.why;
  std::vector<char> flying(log.rows(), 0);
  size_t ir = 0;
  for (size_t r = 0; r < log.rows(); ++r) {
    if (rw.row_kind[r] != realdata::RowKind::kFlight || !Held(tr, t_row[r], &ir)) continue;
    bool ok = (up * (alt)[r] - h0) > options.min_height_m && (!armed || (*armed)[r] != 0);
    for (size_t m = 0; ok && m < n; ++m) ok = (*mu[m])[ir] > kMinFlightOutput;
    flying[r] = ok ? 1 : 0;
  }
  BlockMap bm;
  bm.blocks = std::max(2, options.blocks);
  double ground_from = t_row.empty() ? 0.0 : t_row.front();
  for (size_t r = 0; r < log.rows();) {
    if (!flying[r]) {
      ++r;
      continue;
    }
    size_t e = r;
    while (e + 1 < log.rows() && flying[e + 1]) ++e;
    FlightWindow w{t_row[r] + options.window_edge_s, t_row[e] - options.window_edge_s, "flight",
                   "realdata flight window, every motor output > 0.05, CG above the take-off point (edges trimmed)"};
    if (w.end_s - w.start_s >= kMinWindow_s) {
      out->windows.push_back({ground_from, t_row[r], "ground", "motors idle or stopped, or near the ground"});
      bm.w.push_back(w);
      bm.total_s += w.end_s - w.start_s;
      out->windows.push_back(w);
      ground_from = t_row[e];
    }
    r = e + 1;
  }
  const double log_end = t_row.empty() ? 0.0 : std::min(t_row.back(), cut_s);
  if (log_end > ground_from) {
    out->windows.push_back({ground_from, log_end, "ground", "motors idle or stopped, or near the ground"});
  }
  if (std::isfinite(cut_s) && !t_row.empty()) {
    out->windows.push_back({cut_s, t_row.back(), "excluded", rw.cut_why});
  }
  if (bm.total_s < options.min_flight_s) {
    return Status::BadInput(fmt::format("{}: t_s: {:.1f} s of flight found (needs {:.0f} s with every motor turning above "
                                        "{:.1f} m)", name, bm.total_s, options.min_flight_s, options.min_height_m));
  }

  out->blocks = bm.Spans();
  return bm;
}

// Battery samples in flight: voltage, current and the charge drawn (left and right Riemann sums), the
// median flight voltage V_ref; dropped (with a note) where the log has no power monitor or the current
// is not a measurement.
void BatterySamples(const logs::FlightLog& log, const logs::FlightLog& batt, const BlockMap& bm, double weight_N,
                    FlightSamples* out) {
  const std::vector<double>* bV = Col(batt, "voltage_V");
  const std::vector<double>* bI = Col(batt, "current_A");
  const std::vector<double>* tb = batt.rows() > 0 ? &batt.Column("t_s") : nullptr;
  {
    std::vector<double> vf;
    double q_As = 0.0, q_right_As = 0.0;  // Σ I_{k−1}·Δt and Σ I_k·Δt
    for (size_t k = 0; tb && k < batt.rows(); ++k) {
      if (bI && k > 0 && std::isfinite((*bI)[k - 1]) && std::isfinite((*bI)[k])) {
        q_As += (*bI)[k - 1] * ((*tb)[k] - (*tb)[k - 1]);
        q_right_As += (*bI)[k] * ((*tb)[k] - (*tb)[k - 1]);
      }
      const int b = bm.At((*tb)[k]);
      if (b < 0 || !bV || !std::isfinite((*bV)[k])) continue;
      vf.push_back((*bV)[k]);
      if (!bI || !std::isfinite((*bI)[k])) continue;
      out->batt_t_s.push_back((*tb)[k]);
      out->batt_V.push_back((*bV)[k]);
      out->batt_I.push_back((*bI)[k]);
      out->batt_Q_Ah.push_back(q_As / 3600.0);
      out->batt_Q_right_Ah.push_back(q_right_As / 3600.0);
      out->batt_block.push_back(b);
    }
    out->V_ref = vf.empty() ? 0.0 : Median(vf);
    auto drop_battery = [out] {
      out->batt_t_s.clear();
      out->batt_V.clear();
      out->batt_I.clear();
      out->batt_Q_Ah.clear();
      out->batt_Q_right_Ah.clear();
      out->batt_block.clear();
    };
    if (!vf.empty() && !plausibility::IsPlausible("bus_voltage_V", out->V_ref)) {
      // No power monitor (e.g. 0.06 V logged): neither the voltage nor the current is a measurement.
      out->notes.push_back(fmt::format("logged voltage_V (median {:.3g} V in flight) is outside {}: no power monitor; "
                                      "motor outputs used without voltage scaling, battery kept from the base",
                                      out->V_ref, plausibility::RangeText("bus_voltage_V")));
      out->V_ref = 0.0;
      drop_battery();
    }
    // Electrical power in flight per newton of the base vehicle's weight, where that is the airframe's
    // (IdentifyOptions::base_mass_known; weight_N NaN otherwise: the log does not give the mass): a
    // current below what the induced power needs is not a measurement (an uncalibrated current
    // sensor), and the battery cannot be fitted from it. Without the mass the import's per-motor
    // check (logs/current_check.h) still refuses a current no flying motor draws.
    std::vector<double> P_W;
    for (size_t k = 0; k < out->batt_V.size(); ++k) P_W.push_back(out->batt_V[k] * out->batt_I[k]);
    const double P_per_N = P_W.empty() || !(weight_N > 0) ? std::nan("") : Median(P_W) / weight_N;
    if (std::isfinite(P_per_N) && !plausibility::IsPlausible("flight_power_per_weight_W_per_N", P_per_N)) {
      out->notes.push_back(fmt::format("logged current_A gives {:.3g} W in flight (median V·I), {:.2g} W per newton of the "
                                      "base vehicle's weight, outside {}: the current sensor is not calibrated (e.g. "
                                      "BATT_AMP_PERVOLT); battery kept from the base, the voltage still scales the "
                                      "motor outputs", Median(P_W), P_per_N,
                                      plausibility::RangeText("flight_power_per_weight_W_per_N")));
      drop_battery();
    }
    // The import's data-level check (logs/current_check.h): a current it found unusable fits nothing.
    if (const logs::CurrentSensorCheck current = logs::CurrentSensorOf(log); !current.usable && !out->batt_I.empty()) {
      out->notes.push_back(current.why + "; battery kept from the base");
      drop_battery();
    }
  }
}

// Thrust-curve sums at each RCOU sample (outputs scaled by the held bus voltage) and their first-order
// lagged states on the lag grid.
struct Feature {
  double S1, S2, Z1, Z2;
};
struct CommandFeatures {
  std::vector<Feature> F;
  std::vector<std::array<Feature, kTauCount>> Zs;
  std::vector<double> V_at;
};
CommandFeatures LaggedFeatures(const logs::FlightLog& batt, const std::vector<double>& tr,
                               const std::vector<const std::vector<double>*>& mu, const std::vector<int>& spins,
                               double V_ref) {
  const size_t n = mu.size();
  const bool has_V = V_ref > 0;
  const std::vector<double>* bV = Col(batt, "voltage_V");
  const std::vector<double>* tb = batt.rows() > 0 ? &batt.Column("t_s") : nullptr;
  CommandFeatures cf;
  std::vector<Feature>& F = cf.F;
  std::vector<double>& V_at = cf.V_at;
  std::vector<std::array<Feature, kTauCount>>& Zs = cf.Zs;
  F.resize(tr.size());
  V_at.assign(tr.size(), 1.0);
  size_t ib = 0;
  for (size_t j = 0; j < tr.size(); ++j) {
    double V = V_ref;
    if (has_V && Held(*tb, tr[j], &ib) && std::isfinite((*bV)[ib]) && (*bV)[ib] > 0) V = (*bV)[ib];
    V_at[j] = V;
    Feature f{0, 0, 0, 0};
    for (size_t m = 0; m < n; ++m) {
      const double x = (*mu[m])[j] * (has_V ? V / V_ref : 1.0);
      f.S1 += x;
      f.S2 += x * x;
      f.Z1 += spins[m] * x;
      f.Z2 += spins[m] * x * x;
    }
    F[j] = f;
  }
  // z_j[τ]: the lagged state at RCOU sample j (before its own input acts).
  Zs.resize(tr.size());
  for (size_t j = 0; j < tr.size(); ++j) {
    for (size_t g = 0; g < kTauCount; ++g) {
      // Restart at the steady state of the current input (first sample, a gap, or no lag at all).
      if (j == 0 || tr[j] - tr[j - 1] > kCommandGapReset_s || kTauGrid_s[g] <= 0) {
        Zs[j][g] = F[j];
        continue;
      }
      const double a = std::exp(-(tr[j] - tr[j - 1]) / kTauGrid_s[g]);
      const Feature& p = Zs[j - 1][g];
      const Feature& in = F[j - 1];
      Zs[j][g] = {in.S1 + (p.S1 - in.S1) * a, in.S2 + (p.S2 - in.S2) * a, in.Z1 + (p.Z1 - in.Z1) * a,
                  in.Z2 + (p.Z2 - in.Z2) * a};
    }
  }

  return cf;
}

// Every IMU sample inside a flight block with its held commands, attitude and velocity: specific force,
// rate, yaw acceleration, body velocity, lagged thrust sums; second differences for the noise.
void ImuSamples(const logs::FlightLog& log, const logs::FlightLog& imu, const std::vector<double>& tr,
                const std::vector<const std::vector<double>*>& mu, const CommandFeatures& cf, const BlockMap& bm,
                bool rcou_from_table, FlightSamples* out) {
  const size_t n = mu.size();
  const auto& t_row = log.Column("t_s");
  const std::vector<Feature>& F = cf.F;
  const std::vector<double>& V_at = cf.V_at;
  const auto& Zs = cf.Zs;
  size_t ir = 0;
  const auto& ti = imu.Column("t_s");
  const auto &gx = imu.Column("gyro_x_radps"), &gy = imu.Column("gyro_y_radps"), &gz = imu.Column("gyro_z_radps");
  const auto &ax = imu.Column("accel_x_mps2"), &ay = imu.Column("accel_y_mps2"), &az = imu.Column("accel_z_mps2");
  const double max_gap_s = kImuGapFactor / std::max(out->imu_rate_hz, 1e-9);
  const auto &qw = log.Column("q_w"), &qx = log.Column("q_x"), &qy = log.Column("q_y"), &qz = log.Column("q_z");
  const auto &vn = log.Column("vel_N_mps"), &ve = log.Column("vel_E_mps"), &vd = log.Column("vel_D_mps");
  // Where the commands come from the single table, each held sample stands for a faster loop's
  // commands around it: it is taken to act over the half period before and after its time stamp
  // (a centred hold). A native stream's sample acts from its time stamp until the next one.
  const double hold_shift_s = rcou_from_table && out->rcou_rate_hz > 0 ? 0.5 / out->rcou_rate_hz : 0.0;
  std::vector<double> tl(tr.size());
  for (size_t j = 0; j < tr.size(); ++j) tl[j] = tr[j] - hold_shift_s;
  size_t row = 0, il = 0;
  int prev_k = -3, prev2_k = -3;
  for (size_t k = 0; k < ti.size(); ++k) {
    const int b = bm.At(ti[k]);
    if (b < 0 || !Held(tr, ti[k], &ir) || !Held(tl, ti[k], &il) || !Held(t_row, ti[k], &row)) continue;
    const Vec3 f(ax[k], ay[k], az[k]), w(gx[k], gy[k], gz[k]);
    const Eigen::Quaterniond q(qw[row], qx[row], qy[row], qz[row]);
    const Vec3 vN(vn[row], ve[row], vd[row]);
    if (!f.allFinite() || !w.allFinite() || !q.coeffs().allFinite() || !vN.allFinite()) continue;
    // Yaw acceleration: central difference over the neighbouring IMU samples.
    double rdot = std::nan("");
    if (k > 0 && k + 1 < ti.size() && ti[k + 1] - ti[k - 1] < 2 * max_gap_s && ti[k + 1] > ti[k - 1]) {
      rdot = (gz[k + 1] - gz[k - 1]) / (ti[k + 1] - ti[k - 1]);
    }
    if (!std::isfinite(rdot)) continue;
    LaggedSums s;
    for (size_t g = 0; g < kTauCount; ++g) {
      const Feature& z = Zs[il][g];
      const Feature& in = F[il];
      const double a = kTauGrid_s[g] > 0 ? std::exp(-(ti[k] - tl[il]) / kTauGrid_s[g]) : 0.0;
      s.S1[g] = in.S1 + (z.S1 - in.S1) * a;
      s.S2[g] = in.S2 + (z.S2 - in.S2) * a;
      s.Z1[g] = in.Z1 + (z.Z1 - in.Z1) * a;
      s.Z2[g] = in.Z2 + (z.Z2 - in.Z2) * a;
    }
    double um = 0;
    for (size_t m = 0; m < n; ++m) um += (*mu[m])[ir] / static_cast<double>(n);
    out->t_s.push_back(ti[k]);
    out->f_B.push_back(f);
    out->w_B.push_back(w);
    out->r_dot.push_back(rdot);
    out->v_B.emplace_back(out->velocity_ok ? Vec3(q.normalized().toRotationMatrix().transpose() * vN) : Vec3::Zero());
    out->u_mean.push_back(um);
    std::vector<double> u_k(n);
    for (size_t m = 0; m < n; ++m) u_k[m] = (*mu[m])[ir];
    out->u.push_back(std::move(u_k));
    out->V.push_back(V_at[ir]);
    out->sums.push_back(s);
    out->block.push_back(b);
    // Second differences of three consecutive samples: a smooth motion cancels, white noise stays.
    const size_t m = out->t_s.size();
    if (prev_k == static_cast<int>(k) - 1 && prev2_k == static_cast<int>(k) - 2 && ti[k] - ti[k - 2] < 2 * max_gap_s) {
      out->d_gyro.emplace_back(w - 2.0 * out->w_B[m - 2] + out->w_B[m - 3]);
      out->d_accel.emplace_back(f - 2.0 * out->f_B[m - 2] + out->f_B[m - 3]);
      out->d_block.push_back(b);
    }
    prev2_k = prev_k;
    prev_k = static_cast<int>(k);
  }
}

}  // namespace

std::vector<FrameRotor> FrameRotors(const std::string& frame) {
  // AP_MotorsMatrix::setup_*_matrix: motor i is the i-th entry {angle, yaw factor}; a CCW yaw factor
  // (> 0) is spin +1. Raw-factor frames (hex H) give the angle as atan2(−roll factor, pitch factor).
  using F = std::vector<FrameRotor>;
  static const std::map<std::string, F> kTables = {
      {"quad-plus", F{{90, 1}, {-90, 1}, {0, -1}, {180, -1}}},             // FRAME_TYPE 0
      {"quad-x", F{{45, 1}, {-135, 1}, {-45, -1}, {135, -1}}},             // 1
      {"quad-v", F{{45, 1}, {-135, 1}, {-45, -1}, {135, -1}}},             // 2 (yaw factors ±0.80/±1)
      {"quad-h", F{{45, -1}, {-135, -1}, {-45, 1}, {135, 1}}},             // 3: X with the spins reversed
      {"quad-plus-rev", F{{90, -1}, {-90, -1}, {0, 1}, {180, 1}}},         // 6
      {"quad-bf-x", F{{135, -1}, {45, 1}, {-135, 1}, {-45, -1}}},          // 12 (Betaflight order)
      {"quad-dji-x", F{{45, 1}, {-45, -1}, {-135, 1}, {135, -1}}},         // 13
      {"quad-cw-x", F{{45, 1}, {135, -1}, {-135, 1}, {-45, -1}}},          // 14
      {"quad-bf-x-rev", F{{135, 1}, {45, -1}, {-135, -1}, {-45, 1}}},      // 18
      {"hex-plus", F{{0, -1}, {180, 1}, {-120, -1}, {60, 1}, {-60, 1}, {120, -1}}},     // 0
      {"hex-x", F{{90, -1}, {-90, 1}, {-30, -1}, {150, 1}, {30, 1}, {-150, -1}}},       // 1
      {"hex-h", F{{90, -1}, {-90, 1}, {-45, -1}, {135, 1}, {45, 1}, {-135, -1}}},       // 3
      {"hex-dji-x", F{{30, 1}, {-30, -1}, {-90, 1}, {-150, -1}, {150, 1}, {90, -1}}},   // 13
      {"hex-cw-x", F{{30, 1}, {90, -1}, {150, 1}, {-150, -1}, {-90, 1}, {-30, -1}}},    // 14
      {"octo-x", F{{22.5, -1}, {-157.5, -1}, {67.5, 1}, {157.5, 1}, {-22.5, 1}, {-112.5, 1}, {-67.5, -1}, {112.5, -1}}},
  };
  const auto it = kTables.find(frame);
  return it != kTables.end() ? it->second : F{};
}

std::string FrameNameFor(int frame_class, int frame_type) {
  static const std::map<std::pair<int, int>, const char*> kNames = {
      {{1, 0}, "quad-plus"}, {{1, 1}, "quad-x"},     {{1, 2}, "quad-v"},        {{1, 3}, "quad-h"},
      {{1, 6}, "quad-plus-rev"}, {{1, 12}, "quad-bf-x"}, {{1, 13}, "quad-dji-x"}, {{1, 14}, "quad-cw-x"},
      {{1, 18}, "quad-bf-x-rev"}, {{2, 0}, "hex-plus"},  {{2, 1}, "hex-x"},       {{2, 3}, "hex-h"},
      {{2, 13}, "hex-dji-x"},    {{2, 14}, "hex-cw-x"},  {{3, 1}, "octo-x"},
  };
  const auto it = kNames.find({frame_class, frame_type});
  return it != kNames.end() ? it->second : "";
}

Result<FlightSamples> BuildSamples(const logs::FlightLog& log, const std::vector<int>& spins,
                                   const IdentifyOptions& options, double weight_N) {
  const std::string name = log.meta.value("source", std::string("log"));
  bool imu_from_table = false, rcou_from_table = false;
  const logs::FlightLog imu = logs::StreamAtOwnRate(log, "imu", &imu_from_table);
  const logs::FlightLog rcou = logs::StreamAtOwnRate(log, "rcou", &rcou_from_table);
  const logs::FlightLog batt = logs::StreamAtOwnRate(log, "batt");
  for (const char* c : {"gyro_x_radps", "gyro_y_radps", "gyro_z_radps", "accel_x_mps2", "accel_y_mps2", "accel_z_mps2"}) {
    if (!imu.Has(c)) return Status::BadInput(fmt::format("{}: {}: identification needs the IMU", name, c));
  }
  const size_t n = spins.size();
  std::vector<const std::vector<double>*> mu;
  for (size_t m = 0; m < n; ++m) {
    const auto* c = Col(rcou, fmt::format("motor_{}_u", m + 1));
    if (!c) return Status::BadInput(fmt::format("{}: motor_{}_u: identification needs every motor output", name, m + 1));
    mu.push_back(c);
  }
  for (const char* c : {"q_w", "q_x", "q_y", "q_z", "vel_N_mps", "vel_E_mps", "vel_D_mps"}) {
    if (!log.Has(c)) return Status::BadInput(fmt::format("{}: {}: identification needs attitude and velocity", name, c));
  }
  FlightSamples out;
  double up = 1.0;
  const std::vector<double>* alt = HeightColumn(log, &up, &out.notes);
  if (!alt) return Status::BadInput(name + ": pos_D_m: identification needs a height (pos_D_m or baro_alt_m)");
  const auto& tr = rcou.Column("t_s");

  out.motors = n;
  out.source = fmt::format("IMU {} at {:.0f} Hz, motor outputs {} at {:.0f} Hz", imu_from_table ? "from the table" : "stream",
                           MedianRate_hz(imu.Column("t_s")), rcou_from_table ? "from the table" : "stream",
                           MedianRate_hz(tr));
  out.imu_rate_hz = MedianRate_hz(imu.Column("t_s"));
  out.rcou_rate_hz = MedianRate_hz(tr);
  for (int s : spins) out.z0 += s;

  auto blocks = FlightBlocks(log, tr, mu, *alt, up, options, name, &out);
  if (!blocks.ok()) return blocks.status();
  const BlockMap& bm = *blocks;
  BatterySamples(log, batt, bm, options.base_mass_known ? weight_N : std::nan(""), &out);
  const CommandFeatures cf = LaggedFeatures(batt, tr, mu, spins, out.V_ref);
  ImuSamples(log, imu, tr, mu, cf, bm, rcou_from_table, &out);
  if (out.t_s.size() < 100) {
    return Status::BadInput(fmt::format("{}: t_s: only {} IMU samples in flight windows", name, out.t_s.size()));
  }
  return out;
}

}  // namespace hexsim::identify::internal
