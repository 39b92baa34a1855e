#include "hexsim/realdata/compass_flight.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "hexsim/common/plausibility.h"
#include "hexsim/magnetics/wmm.h"

namespace hexsim::realdata {
namespace {

using Eigen::Matrix3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;

constexpr double kThrottlePerControl = 1e-3;  // control_u is the collective in 0…1000

double Median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  const auto k = static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[static_cast<size_t>(k)];
}

// Linear interpolation of a row column at ascending query times (a moving cursor): NaN outside the
// rows or where a neighbouring row is not finite.
class RowInterp {
 public:
  RowInterp(const std::vector<double>& t, const std::vector<double>* v) : t_(t), v_(v) {}
  double At(double tq) {
    if (v_ == nullptr || t_.size() < 2 || !(tq >= t_.front()) || !(tq <= t_.back())) return std::nan("");
    while (i_ > 0 && t_[i_] > tq) --i_;
    while (i_ + 2 < t_.size() && t_[i_ + 1] < tq) ++i_;
    const double dt = t_[i_ + 1] - t_[i_];
    const double w = dt > 0 ? (tq - t_[i_]) / dt : 0.0;
    return (1 - w) * (*v_)[i_] + w * (*v_)[i_ + 1];
  }

 private:
  const std::vector<double>& t_;
  const std::vector<double>* v_;
  size_t i_ = 0;
};

// The current's own samples, linearly interpolated at tq; NaN before the first and after the last.
double SampleAt(const HeldSamples& s, double tq, size_t* cursor) {
  if (s.t.empty() || !(tq >= s.t.front()) || !(tq <= s.t.back())) return std::nan("");
  size_t& i = *cursor;
  while (i > 0 && s.t[i] > tq) --i;
  while (i + 2 < s.t.size() && s.t[i + 1] < tq) ++i;
  if (s.t.size() == 1) return s.v[0];
  const double dt = s.t[i + 1] - s.t[i];
  const double w = dt > 0 ? std::clamp((tq - s.t[i]) / dt, 0.0, 1.0) : 0.0;
  return (1 - w) * s.v[i] + w * s.v[i + 1];
}

struct Inputs {
  const std::vector<double>* t_row = nullptr;
  std::vector<const std::vector<double>*> q;  // q_w, q_x, q_y, q_z
  const std::vector<double>* control_u = nullptr;
  HeldSamples current;
  bool use_current = false;
};

// The log's motor count (meta motor_count, else its motor_i_u columns), at least 1.
int MotorCount(const logs::FlightLog& log) {
  int motors = 0;
  while (log.Has(fmt::format("motor_{}_u", motors + 1))) ++motors;
  if (log.meta.is_object() && log.meta.contains("motor_count") && log.meta["motor_count"].is_number()) {
    motors = log.meta["motor_count"].get<int>();
  }
  return std::max(motors, 1);
}

// Samples inside a flight window whose current says the motors were not carrying the vehicle (under
// min_current_per_motor_A per motor, the import's own bound: no multirotor hovers on less) are
// ground samples: a window's hysteresis can hold a log's first seconds with the motors stopped
// (ArduCopter log_0041: 2.1 s at 0 A before the motors spin). Such samples sit at zero current on
// the ground, where the local field is not the airborne one, and lever the current term.
std::vector<size_t> Airborne(const std::vector<size_t>& pick, const std::vector<magnetics::FlightFitSample>& s,
                             double min_current_A, int* dropped) {
  std::vector<size_t> out;
  out.reserve(pick.size());
  for (size_t k = 0; k < pick.size(); ++k) {
    if (std::isfinite(s[k].current_A) && s[k].current_A < min_current_A) {
      ++*dropped;
      continue;
    }
    out.push_back(pick[k]);
  }
  return out;
}

// Whether the log's current can drive the fit; the reason where not.
std::string CurrentUnusable(const logs::FlightLog& log, const FlightWindows& w, const CompassFlightOptions& o) {
  if (log.meta.is_object() && log.meta.contains("current_usable") && log.meta["current_usable"].is_boolean() &&
      !log.meta["current_usable"].get<bool>()) {
    const std::string why = log.meta.value("current_unusable_why", std::string());
    return why.empty() ? "current sensor unusable (import check)" : why;
  }
  if (!log.Has("current_A")) return "no current logged";
  std::vector<double> flight;
  size_t flight_rows = 0;
  const auto& c = log.Column("current_A");
  for (size_t i = 0; i < c.size() && i < w.row_kind.size(); ++i) {
    if (w.row_kind[i] != RowKind::kFlight) continue;
    ++flight_rows;
    if (std::isfinite(c[i])) flight.push_back(c[i]);
  }
  // The current is judged where the motors carry the vehicle; on the ground it says nothing of them.
  if (flight_rows == 0) return "no flight window to judge the current in (it is used in flight only)";
  if (flight.empty()) return "no current logged in flight";
  const int motors = MotorCount(log);
  const double med = Median(flight);
  if (!(med >= o.min_current_per_motor_A * motors)) {
    return fmt::format("current sensor unusable: flight median {:.2f} A under {:.1f} A per motor over {} motors", med,
                       o.min_current_per_motor_A, motors);
  }
  return "";
}

// The samples of the fit on a trial latency (selection fixed by `pick`).
std::vector<magnetics::FlightFitSample> Build(const logs::MagInput& in, const std::vector<size_t>& pick, const Inputs& x,
                                              double latency_s, double shift_s) {
  std::vector<magnetics::FlightFitSample> out;
  out.reserve(pick.size());
  RowInterp qi[4] = {{*x.t_row, x.q[0]}, {*x.t_row, x.q[1]}, {*x.t_row, x.q[2]}, {*x.t_row, x.q[3]}};
  RowInterp ui(*x.t_row, x.control_u);
  size_t cur = 0;
  for (size_t i : pick) {
    const double tau = in.t_s[i] - latency_s;
    Quaterniond q(qi[0].At(tau), qi[1].At(tau), qi[2].At(tau), qi[3].At(tau));
    if (!q.coeffs().allFinite() || q.norm() < 0.5) {
      const Eigen::Vector4d& r = in.q_wxyz[i];  // beyond the rows: the sample's own row
      q = Quaterniond(r(0), r(1), r(2), r(3));
    }
    magnetics::FlightFitSample s;
    s.y_uT = in.body_from_raw * in.field[i];
    s.R_NB = q.normalized().toRotationMatrix();
    s.current_A = x.use_current ? SampleAt(x.current, tau + shift_s, &cur) : std::nan("");
    s.throttle = kThrottlePerControl * ui.At(tau);
    s.t_s = in.t_s[i];
    out.push_back(s);
  }
  return out;
}

// The current at every trial shift of `grid` for the samples of `pick` on latency latency_s.
magnetics::RegressorMembers CurrentMembers(const logs::MagInput& in, const std::vector<size_t>& pick, const Inputs& x,
                                           double latency_s, const std::vector<double>& grid) {
  magnetics::RegressorMembers m;
  m.shift_s = grid;
  for (double shift : grid) {
    std::vector<double> v;
    v.reserve(pick.size());
    size_t cur = 0;
    for (size_t i : pick) v.push_back(SampleAt(x.current, in.t_s[i] - latency_s + shift, &cur));
    m.value.push_back(std::move(v));
  }
  return m;
}

// The model on latency latency_s: with the current's shift profiled over `grid` where there is one
// (the samples then carry the chosen member's current), else on `shift_s`.
Result<magnetics::FlightFit> FitOnLatency(const logs::MagInput& in, const std::vector<size_t>& pick, const Inputs& x,
                                          double latency_s, const std::vector<double>& grid, double shift_s,
                                          const magnetics::FlightFitOptions& fo, std::vector<magnetics::FlightFitSample>* s) {
  if (grid.size() < 2) {
    *s = Build(in, pick, x, latency_s, shift_s);
    return magnetics::FitFlightCompass(*s, fo);
  }
  *s = Build(in, pick, x, latency_s, grid.front());
  auto fit = magnetics::FitFlightCompassProfiled(*s, CurrentMembers(in, pick, x, latency_s, grid), fo);
  if (fit.ok()) *s = Build(in, pick, x, latency_s, fit->term_fitted ? fit->regressor_shift_s : shift_s);
  return fit;
}

// Per-block SSE of the model fitted at each trial latency, over the samples the unshifted fit used.
LagEstimate ScanLatency(const logs::MagInput& in, const std::vector<size_t>& pick, const Inputs& x, double shift_s,
                        const magnetics::FlightFitOptions& fo, const std::vector<char>& used0, const CompassFlightOptions& o) {
  const std::vector<double> grid = LagGrid(o.latency_lo_s, o.latency_hi_s, o.latency_step_s);
  const double t0 = in.t_s[pick.front()];
  const auto blocks = static_cast<size_t>(std::floor((in.t_s[pick.back()] - t0) / fo.block_s)) + 1;
  std::vector<std::vector<double>> sse(grid.size(), std::vector<double>(blocks, 0.0));
  magnetics::FlightFitOptions trial = fo;
  trial.intervals = false;
  for (size_t g = 0; g < grid.size(); ++g) {
    const auto s = Build(in, pick, x, grid[g], shift_s);
    auto fit = magnetics::FitFlightCompass(s, trial);
    if (!fit.ok()) return {};
    for (size_t k = 0; k < s.size(); ++k) {
      if (used0[k] == 0) continue;
      const auto b = static_cast<size_t>(std::floor((s[k].t_s - t0) / fo.block_s));
      sse[g][std::min(b, blocks - 1)] += (s[k].y_uT - fit->Predict(s[k])).squaredNorm();
    }
  }
  return ProfileLag(grid, sse, o.resamples, o.seed);
}

// dI/du by least squares over the fitted samples with both.
double CurrentPerThrottle(const std::vector<magnetics::FlightFitSample>& s) {
  double mu = 0, mi = 0;
  int n = 0;
  for (const auto& v : s) {
    if (!std::isfinite(v.current_A) || !std::isfinite(v.throttle)) continue;
    mu += v.throttle;
    mi += v.current_A;
    ++n;
  }
  if (n < 10) return std::nan("");
  mu /= n;
  mi /= n;
  double sxy = 0, sxx = 0;
  for (const auto& v : s) {
    if (!std::isfinite(v.current_A) || !std::isfinite(v.throttle)) continue;
    sxy += (v.throttle - mu) * (v.current_A - mi);
    sxx += (v.throttle - mu) * (v.throttle - mu);
  }
  return sxx > 0 ? sxy / sxx : std::nan("");
}

// Flight samples (inside a flight window) when they are enough, tilt within range; fills the notes.
std::vector<size_t> Pick(const logs::MagInput& in, const FlightWindows& w, int min_samples, double max_tilt_deg,
                         CompassFlight* out) {
  std::vector<char> flight(in.t_s.size(), 0);
  std::string spans;
  bool airborne_window = false;
  for (const auto& win : w.windows) {
    if (win.kind != "flight") continue;
    airborne_window = airborne_window || !win.on_ground;
    spans += (spans.empty() ? "" : ", ") +
             fmt::format("{:.1f}-{:.1f} s{}", win.start_s, win.end_s, win.on_ground ? " (on the ground: motors running, no climb)" : "");
    for (size_t i = 0; i < in.t_s.size(); ++i) {
      if (in.t_s[i] >= win.start_s && in.t_s[i] <= win.end_s) flight[i] = 1;
    }
  }
  const std::string where = (spans.empty() ? std::string("no flight window") : "flight " + spans) + "; armed state from " +
                            w.armed_source;
  out->flight_only = std::count(flight.begin(), flight.end(), 1) >= min_samples;
  out->windows_note = out->flight_only ? "flight windows only (" + where + ")"
                                       : "too few flight samples: ground samples used too (" + where + ")";
  if (!out->flight_only) {
    out->ground_run_note = "on ground samples (too few flight samples)";
  } else if (!airborne_window) {
    out->ground_run_note = "on runs on the ground only (motors at flight output, no climb: tied down or props off)";
  }
  const double cos_max_tilt = std::cos(max_tilt_deg * M_PI / 180.0);
  std::vector<size_t> pick;
  for (size_t i = 0; i < in.t_s.size(); ++i) {
    if (out->flight_only && flight[i] == 0) {
      ++out->outside;
      continue;
    }
    const Eigen::Vector4d& r = in.q_wxyz[i];
    const Matrix3d R = Quaterniond(r(0), r(1), r(2), r(3)).normalized().toRotationMatrix();
    if (R(2, 2) < cos_max_tilt) {  // body z against down: cos(tilt)
      ++out->tilted;
      continue;
    }
    pick.push_back(i);
  }
  return pick;
}

// Too few samples for the model: the count and where the others went (a short log's flight windows
// hold ground seconds whose samples the current check removes; nothing is lost to the attitude).
Status TooFew(const logs::MagInput& in, size_t kept, const CompassFlightOptions& o, const CompassFlight& out, int motors) {
  return Status::BadInput(fmt::format(
      "flight fit: {} samples, needs at least {}: of the compass's {} samples {} lie outside the flight windows, {} tilted "
      "beyond {:.0f} deg, {} under {:.1f} A ({:.1f} A per motor: motors not carrying the vehicle)",
      kept, o.fit.min_samples, in.t_s.size(), out.outside, out.tilted, o.max_tilt_deg, out.not_airborne,
      o.min_current_per_motor_A * motors, o.min_current_per_motor_A));
}

}  // namespace

magnetics::MotorCompensationInLog MotorCompensationOf(const logs::FlightLog& log, const std::string& compass) {
  magnetics::MotorCompensationInLog m;
  const auto& meta = log.meta;
  if (!meta.is_object() || !meta.contains("compass_motct") || !meta["compass_motct"].is_number()) return m;
  m.motct = meta["compass_motct"].get<int>();
  if (!meta.contains("compasses") || !meta["compasses"].is_array()) return m;
  for (const auto& c : meta["compasses"]) {
    if (c.value("column", "") != compass || !c.contains("motor_compensation_mG")) continue;
    const auto& v = c["motor_compensation_mG"];
    if (v.is_array() && v.size() == 3) m.mot = Vector3d(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
  }
  return m;
}

std::string TimingNote(const CompassFlight& f) {
  std::string s = f.options.field_free ? "no place and date (no GPS fix): Earth field fitted freely, without the WMM prior; " : "";
  s += f.latency.ok() ? fmt::format("compass latency {:.0f} ms [{:.0f}, {:.0f}] {}", 1000 * f.latency.value_s,
                                               1000 * f.latency.ci95_s[0], 1000 * f.latency.ci95_s[1],
                                               f.latency_applied ? "applied" : "not applied (not resolved from 0 or implausible)")
                                 : std::string("compass latency not scanned");
  if (f.staleness.ok()) {
    s += fmt::format("; current against throttle {:.0f} ms [{:.0f}, {:.0f}] (staleness plus the motors' response)",
                     1000 * f.staleness.value_s, 1000 * f.staleness.ci95_s[0], 1000 * f.staleness.ci95_s[1]);
  }
  const std::vector<double>& g = f.current_shift_grid_s;
  if (g.size() >= 2 && f.fit.term_fitted) {
    s += fmt::format("; current shifted by {:.0f} ms, chosen by the compass fit over {:.0f}-{:.0f} ms in {:.0f} ms steps "
                     "(delete-one-block fits chose {:.0f}-{:.0f} ms)",
                     1000 * f.current_shift_s, 1000 * g.front(), 1000 * g.back(), 1000 * (g[1] - g[0]),
                     1000 * f.current_shift_range_s[0], 1000 * f.current_shift_range_s[1]);
  } else if (f.staleness.ok()) {
    s += fmt::format("; current shifted by {:.0f} ms", 1000 * f.current_shift_s);
  }
  return s;
}

LagEstimate CurrentStaleness(const logs::FlightLog& log, const std::vector<RowKind>& kinds, const StalenessOptions& options) {
  if (!log.Has("current_A") || !log.Has("control_u")) return {};
  const auto& t = log.Column("t_s");
  // Each logged sample once, at its own time stamp where the log has one.
  std::vector<double> tu, u;
  {
    const auto& c = log.Column("control_u");
    const std::vector<double>* tc = log.Has("ctun_t_s") ? &log.Column("ctun_t_s") : nullptr;
    double last = -1e300;
    for (size_t i = 0; i < log.rows(); ++i) {
      if (kinds[i] != RowKind::kFlight || !std::isfinite(c[i])) continue;
      const double ti = tc ? (*tc)[i] : t[i];
      if (!std::isfinite(ti) || ti <= last) continue;
      last = ti;
      tu.push_back(ti);
      u.push_back(c[i]);
    }
  }
  // The current is a sample-and-hold channel: each sample where it first appears.
  std::vector<double> tr, ts, Ir;
  const auto& c = log.Column("current_A");
  const std::vector<double>* tc = log.Has("batt_t_s") ? &log.Column("batt_t_s") : nullptr;
  for (size_t i = 0; i < log.rows(); ++i) {
    if (kinds[i] != RowKind::kFlight) continue;
    tr.push_back(t[i]);
    ts.push_back(tc ? (*tc)[i] : std::nan(""));
    Ir.push_back(c[i]);
  }
  const HeldSamples held = FirstAppearances(tr, ts, Ir);
  return StalenessScan(tu, u, held.t, held.v, options);
}

bool StalenessResolved(const LagEstimate& s) {
  return s.resolved() && plausibility::IsPlausible("current_staleness", s.value_s);
}

double AppliedCurrentShift_s(const LagEstimate& s) { return StalenessResolved(s) ? std::max(0.0, s.value_s) : 0.0; }

double UpdatePeriod_s(const std::vector<double>& sample_t) {
  std::vector<double> gaps;
  for (size_t k = 1; k < sample_t.size(); ++k) gaps.push_back(sample_t[k] - sample_t[k - 1]);
  return Median(gaps);
}

std::vector<double> CurrentShiftGrid(const LagEstimate& staleness, double update_period_s) {
  const plausibility::PhysicalRange* range = plausibility::FindRange("current_staleness");
  const double range_hi = range != nullptr ? range->hi : 1.0;
  const bool period_known = std::isfinite(update_period_s) && update_period_s > 0;
  double hi = range_hi;
  if (StalenessResolved(staleness) && period_known) hi = std::min(range_hi, staleness.ci95_s[1] + update_period_s);
  const double step = period_known ? std::clamp(0.25 * update_period_s, kMinShiftStep_s, kMaxShiftStep_s) : kMaxShiftStep_s;
  return LagGrid(0.0, hi, step);
}

Result<CompassFlight> FitCompassInFlight(const logs::FlightLog& log, const logs::MagInput& in, const FlightWindows& w,
                                         const CompassFlightOptions& o) {
  if (in.q_wxyz.size() != in.field.size() || in.t_s.size() != in.field.size() || !log.Has("t_s")) {
    return Status::BadInput("--method flight: the input has no attitude (it needs a flight log: FlightLog CSV, .bin or .ulg)");
  }
  if (!(std::fabs(in.body_from_raw.determinant()) > 1e-6)) {
    return Status::BadInput("--method flight: the log's compass matrix is singular");
  }
  CompassFlight out;
  out.options = o.fit;
  if (in.has_place) {
    auto wmm = magnetics::EvaluateWmm({in.lat_deg, in.lon_deg, in.alt_m}, in.decimal_year, /*allow_extrapolation=*/true);
    if (!wmm.ok()) return wmm.status();
    out.options.prior_field_N_uT = wmm->B_N_uT;
  } else {
    // No GPS fix: the model's Earth-field terms are fitted freely (flight_fit.h field_free).
    out.options.field_free = true;
    out.options.prior_field_N_uT.setZero();
  }
  std::vector<size_t> pick = Pick(in, w, o.fit.min_samples, o.max_tilt_deg, &out);
  if (pick.size() < 2) return Status::BadInput(fmt::format("flight fit: {} usable samples, needs {}", pick.size(), o.fit.min_samples));
  const double span_s = in.t_s[pick.back()] - in.t_s[pick.front()];
  out.options.block_s = std::min(o.fit.block_s, std::max(o.min_block_s, span_s / (2.0 * o.fit.min_blocks)));

  Inputs x;
  x.t_row = &log.Column("t_s");
  for (const char* c : {"q_w", "q_x", "q_y", "q_z"}) x.q.push_back(log.Has(c) ? &log.Column(c) : nullptr);
  if (std::find(x.q.begin(), x.q.end(), nullptr) != x.q.end()) x.q.assign(4, nullptr);
  if (x.q[0] == nullptr) return Status::BadInput("--method flight: the log has no attitude columns q_w..q_z");
  x.control_u = log.Has("control_u") ? &log.Column("control_u") : nullptr;
  out.current_note = CurrentUnusable(log, w, o);
  out.current_usable = out.current_note.empty();
  const bool throttle = o.term == TermChoice::kThrottle || (o.term == TermChoice::kAuto && !out.current_usable);
  out.options.form = throttle ? magnetics::FlightTermForm::kThrottle : magnetics::FlightTermForm::kCurrent;
  if (log.Has("current_A") && (out.current_usable || o.term == TermChoice::kCurrent)) {
    x.use_current = true;
    const std::vector<double> none;
    x.current = FirstAppearances(*x.t_row, log.Has("batt_t_s") ? log.Column("batt_t_s") : none, log.Column("current_A"));
    StalenessOptions so;
    so.seed = o.seed;
    so.resamples = o.resamples;
    out.staleness = o.staleness != nullptr ? *o.staleness : CurrentStaleness(log, w.row_kind, so);
    // The scan's point shift until the profile has chosen (the airborne check's current).
    out.current_shift_s = AppliedCurrentShift_s(out.staleness);
    if (!throttle) out.current_shift_grid_s = CurrentShiftGrid(out.staleness, UpdatePeriod_s(x.current.t));
  }
  std::vector<magnetics::FlightFitSample> s = Build(in, pick, x, 0.0, out.current_shift_s);
  if (x.use_current && out.flight_only) {
    pick = Airborne(pick, s, o.min_current_per_motor_A * MotorCount(log), &out.not_airborne);
    if (out.not_airborne > 0) {
      s = Build(in, pick, x, 0.0, out.current_shift_s);
      out.windows_note += fmt::format("; {} sample(s) under {:.1f} A ({:.1f} A per motor: motors not carrying the vehicle) "
                                      "left out", out.not_airborne, o.min_current_per_motor_A * MotorCount(log),
                                      o.min_current_per_motor_A);
    }
  }
  if (static_cast<int>(pick.size()) < o.fit.min_samples) return TooFew(in, pick.size(), o, out, MotorCount(log));
  const std::vector<double>& grid = out.current_shift_grid_s;
  if (o.scan_latency && static_cast<int>(pick.size()) >= o.fit.min_samples) {
    magnetics::FlightFitOptions trial = out.options;
    trial.intervals = false;
    auto fit0 = FitOnLatency(in, pick, x, 0.0, grid, out.current_shift_s, trial, &s);
    if (fit0.ok() && fit0->term_fitted) out.current_shift_s = fit0->regressor_shift_s;
    if (fit0.ok()) out.latency = ScanLatency(in, pick, x, out.current_shift_s, out.options, fit0->used, o);
    // Align only a resolved latency (its interval clear of zero) inside its physical range.
    out.latency_applied = out.latency.resolved() &&
                          (out.latency.ci95_s[0] > 0 || out.latency.ci95_s[1] < 0) &&
                          plausibility::IsPlausible("latency", out.latency.value_s);
    if (out.latency_applied) out.latency_s = out.latency.value_s;
  }
  auto fit = FitOnLatency(in, pick, x, out.latency_s, grid, out.current_shift_s, out.options, &s);
  if (!fit.ok()) return fit.status();
  out.fit = std::move(*fit);
  if (grid.size() >= 2 && out.fit.term_fitted) {
    out.current_shift_s = out.fit.regressor_shift_s;
    out.current_shift_range_s[0] = out.fit.regressor_shift_range_s[0];
    out.current_shift_range_s[1] = out.fit.regressor_shift_range_s[1];
  } else {
    out.current_shift_range_s[0] = out.current_shift_range_s[1] = out.current_shift_s;
  }
  if (out.current_usable && x.use_current) out.current_per_throttle_A = CurrentPerThrottle(s);
  out.samples = std::move(s);
  for (size_t i : pick) out.index.push_back(i);
  return out;
}

}  // namespace hexsim::realdata
