// Flight windows and phases (see windows.h).
#include "hexsim/realdata/windows.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "hexsim/logs/current_check.h"

namespace hexsim::realdata {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kRadToDeg = 57.29577951308232;
constexpr double kThrottleFullScale = 1000.0;  // control_u units per full throttle
// A multirotor that hovers below a quarter throttle would have a thrust-to-weight ratio above ~16
// (thrust ∝ u²): an armed level that low is idle, not flight.
constexpr double kMaxIdleThrottle = 0.25;

const std::vector<double>* Col(const logs::FlightLog& log, const char* name) {
  return log.Has(name) ? &log.Column(name) : nullptr;
}

const char* KindName(RowKind k) {
  switch (k) {
    case RowKind::kFlight:
      return "flight";
    case RowKind::kGround:
      return "ground";
    default:
      return "excluded";
  }
}

// Largest of |roll| and |pitch| (deg) from q (Hamilton, body FRD → NED).
double TiltDeg(double w, double x, double y, double z) {
  const double roll = std::atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y));
  const double pitch = std::asin(std::clamp(2 * (w * y - z * x), -1.0, 1.0));
  return std::max(std::fabs(roll), std::fabs(pitch)) * kRadToDeg;
}

// A flight window [i, j) whose logged height spans less than a flight climbs (logs::kMinFlightClimb_m,
// the import's current check's rule) is a run on the ground.
void MarkOnGround(const logs::FlightLog& log, size_t i, size_t j, Window* w) {
  std::vector<size_t> rows(j - i);
  for (size_t k = i; k < j; ++k) rows[k - i] = k;
  std::string column;
  const double span_m = logs::LoggedHeightSpan_m(log, rows, &column);
  if (!(span_m < logs::kMinFlightClimb_m)) return;
  w->on_ground = true;
  w->why = fmt::format("armed, throttle above idle, but {} spans {:.2g} m (a flight climbs {:g} m or more): a run on the "
                       "ground (tied down or props off): the compasses' current terms use it, the inertial and "
                       "dynamics replays do not",
                       column, span_m, logs::kMinFlightClimb_m);
}

}  // namespace

FlightWindows::FlightWindows() : cut_at_s(kNaN), idle_throttle(kNaN) {}

size_t FlightWindows::Count(RowKind kind) const {
  return static_cast<size_t>(std::count(row_kind.begin(), row_kind.end(), kind));
}

std::vector<std::string> MergeShortSegments(const std::vector<double>& t, std::vector<std::string> labels,
                                            double min_segment_s, const std::vector<std::string>& fixed) {
  const size_t n = labels.size();
  if (n == 0) return labels;
  auto is_fixed = [&](const std::string& l) { return std::find(fixed.begin(), fixed.end(), l) != fixed.end(); };
  struct Run {
    size_t a, b;  // rows [a, b)
    std::string label;
    double len;
  };
  auto length = [&](size_t a, size_t b) { return (b < n ? t[b] : t[n - 1]) - t[a]; };
  std::vector<Run> runs;
  for (size_t i = 0; i < n;) {
    size_t j = i;
    while (j < n && labels[j] == labels[i]) ++j;
    runs.push_back({i, j, labels[i], length(i, j)});
    i = j;
  }
  // Repeatedly absorb the shortest too-short run into its longer non-fixed neighbour.
  while (runs.size() > 1) {
    size_t s = runs.size();
    for (size_t r = 0; r < runs.size(); ++r) {
      if (runs[r].len >= min_segment_s || is_fixed(runs[r].label)) continue;
      const bool prev_ok = r > 0 && !is_fixed(runs[r - 1].label);
      const bool next_ok = r + 1 < runs.size() && !is_fixed(runs[r + 1].label);
      if ((prev_ok || next_ok) && (s == runs.size() || runs[r].len < runs[s].len)) s = r;
    }
    if (s == runs.size()) break;
    const bool prev_ok = s > 0 && !is_fixed(runs[s - 1].label);
    const bool next_ok = s + 1 < runs.size() && !is_fixed(runs[s + 1].label);
    const size_t into = prev_ok && next_ok ? (runs[s - 1].len >= runs[s + 1].len ? s - 1 : s + 1) : (prev_ok ? s - 1 : s + 1);
    runs[s].label = runs[into].label;
    // Coalesce equal neighbours around s.
    std::vector<Run> merged;
    for (const Run& r : runs) {
      if (!merged.empty() && merged.back().label == r.label) {
        merged.back().b = r.b;
        merged.back().len = length(merged.back().a, r.b);
      } else {
        merged.push_back(r);
      }
    }
    runs.swap(merged);
  }
  for (const Run& r : runs) {
    for (size_t i = r.a; i < r.b; ++i) labels[i] = r.label;
  }
  return labels;
}

FlightWindows FindFlightWindows(const logs::FlightLog& log, const WindowOptions& o) {
  FlightWindows fw;
  const size_t n = log.rows();
  fw.row_kind.assign(n, RowKind::kGround);
  if (n == 0 || !log.Has("t_s")) return fw;
  const auto& t = log.Column("t_s");
  const auto *qw = Col(log, "q_w"), *qx = Col(log, "q_x"), *qy = Col(log, "q_y"), *qz = Col(log, "q_z");
  const auto *ax = Col(log, "accel_x_mps2"), *ay = Col(log, "accel_y_mps2"), *az = Col(log, "accel_z_mps2");
  const auto* thr = Col(log, "control_u");
  const auto* armed = Col(log, "armed");

  // 1. The cut: the first sustained over-tilt or impact; everything after it is excluded.
  double cut = kNaN;
  if (qw && qx && qy && qz) {
    std::vector<double> tilt(n, kNaN);
    for (size_t i = 0; i < n; ++i) tilt[i] = TiltDeg((*qw)[i], (*qx)[i], (*qy)[i], (*qz)[i]);
    for (size_t i = 0; i < n && std::isnan(cut); ++i) {
      if (!(tilt[i] > o.max_tilt_deg)) continue;
      size_t j = i;
      while (j < n && tilt[j] > o.max_tilt_deg) ++j;
      const double held = (j < n ? t[j] : t[n - 1]) - t[i];
      if (held >= o.sustained_s || j == n) {
        size_t s = i;
        while (s > 0 && !(tilt[s] < o.sane_tilt_deg)) --s;
        cut = t[s] - o.lead_s;
        fw.cut_why = fmt::format("flip or crash: |roll| or |pitch| above {:g} deg for {:.1f} s from {:.1f} s", o.max_tilt_deg,
                                 held, t[i]);
      }
      i = j;
    }
  }
  // An impact is a crash only when the flight ends within crash_settle_s of it (the log ends, the
  // vehicle over-tilts, the autopilot disarms, or the throttle falls to idle): a spike the vehicle flies on through (a bump
  // at spin-up, a vibration burst) is not one.
  const auto flight_ends_after = [&](size_t i) {
    for (size_t j = i + 1; j < n; ++j) {
      if (t[j] - t[i] > o.crash_settle_s) return false;
      if (!std::isnan(cut) && t[j] >= cut) return true;  // the flip or over-tilt found above
      if (armed && (*armed)[j] == 0.0) return true;
      if (!armed && thr && (*thr)[j] / kThrottleFullScale < o.idle_margin) return true;
    }
    return true;  // the log ends
  };
  if (ax && ay && az) {
    for (size_t i = 0; i < n; ++i) {
      const double f = std::sqrt((*ax)[i] * (*ax)[i] + (*ay)[i] * (*ay)[i] + (*az)[i] * (*az)[i]);
      if (f > o.impact_mps2 && (std::isnan(cut) || t[i] - o.lead_s < cut) && flight_ends_after(i)) {
        cut = t[i] - o.lead_s;
        fw.cut_why = fmt::format("impact: |specific force| {:.0f} m/s^2 at {:.1f} s", f, t[i]);
        break;
      }
    }
  }
  fw.cut_at_s = cut;

  // 2. Armed state and idle throttle.
  std::vector<double> u(n, kNaN);
  if (thr) {
    for (size_t i = 0; i < n; ++i) u[i] = (*thr)[i] / kThrottleFullScale;
  }
  std::vector<bool> is_armed(n, true);
  if (armed) {
    fw.armed_source = "armed column (autopilot arm/disarm events)";
    for (size_t i = 0; i < n; ++i) is_armed[i] = (*armed)[i] > 0.5;
  } else if (thr) {
    fw.armed_source = "no armed state in the log: throttle above zero taken as armed";
    for (size_t i = 0; i < n; ++i) is_armed[i] = u[i] > 0;
  } else {
    fw.armed_source = "no armed state nor throttle in the log: every row taken as flight";
  }
  std::vector<double> armed_u;
  for (size_t i = 0; i < n; ++i) {
    if (is_armed[i] && std::isfinite(u[i]) && (std::isnan(cut) || t[i] < cut)) armed_u.push_back(u[i]);
  }
  double idle = kNaN;
  if (!armed_u.empty()) {
    const size_t k = armed_u.size() / 100;  // 1st percentile: robust to a single glitch
    std::nth_element(armed_u.begin(), armed_u.begin() + static_cast<std::ptrdiff_t>(k), armed_u.end());
    idle = armed_u[k] <= kMaxIdleThrottle ? armed_u[k] : 0.0;
  }
  fw.idle_throttle = idle;

  // 3. Row kinds, then hysteresis.
  std::vector<std::string> lab(n);
  for (size_t i = 0; i < n; ++i) {
    RowKind k = RowKind::kFlight;
    if (!std::isnan(cut) && t[i] >= cut) k = RowKind::kExcluded;
    else if (!is_armed[i]) k = RowKind::kGround;
    else if (thr && !(u[i] > idle + o.idle_margin)) k = RowKind::kGround;
    lab[i] = KindName(k);
  }
  lab = MergeShortSegments(t, lab, o.min_segment_s, {"excluded"});
  for (size_t i = 0; i < n; ++i) {
    fw.row_kind[i] = lab[i] == "flight" ? RowKind::kFlight : lab[i] == "ground" ? RowKind::kGround : RowKind::kExcluded;
  }
  for (size_t i = 0; i < n;) {
    size_t j = i;
    while (j < n && lab[j] == lab[i]) ++j;
    Window w{t[i], t[j - 1], lab[i], "", false};
    if (lab[i] == "flight") w.why = "armed, throttle above idle, attitude sane";
    if (lab[i] == "flight") MarkOnGround(log, i, j, &w);
    else if (lab[i] == "ground") w.why = "disarmed or at idle throttle, before any flip or crash";
    else w.why = fw.cut_why;
    fw.windows.push_back(w);
    i = j;
  }
  return fw;
}

std::vector<RowKind> AirborneRowKind(const logs::FlightLog& log, const FlightWindows& fw) {
  std::vector<RowKind> kind = fw.row_kind;
  if (!log.Has("t_s") || log.rows() != kind.size()) return kind;
  const auto& t = log.Column("t_s");
  for (const Window& w : fw.windows) {
    if (!w.on_ground) continue;
    for (size_t i = 0; i < kind.size(); ++i) {
      if (kind[i] == RowKind::kFlight && t[i] >= w.start_s && t[i] <= w.end_s) kind[i] = RowKind::kGround;
    }
  }
  return kind;
}

FlightWindows WindowsFromRange(const logs::FlightLog& log, double from_s, double to_s) {
  FlightWindows fw;
  fw.overridden = true;
  fw.armed_source = fmt::format("--from {:g} --to {:g}", from_s, to_s);
  const size_t n = log.rows();
  fw.row_kind.assign(n, RowKind::kExcluded);
  if (n == 0 || !log.Has("t_s")) return fw;
  const auto& t = log.Column("t_s");
  for (size_t i = 0; i < n; ++i) {
    if (t[i] >= from_s && t[i] <= to_s) fw.row_kind[i] = RowKind::kFlight;
  }
  for (size_t i = 0; i < n;) {
    size_t j = i;
    while (j < n && fw.row_kind[j] == fw.row_kind[i]) ++j;
    const bool in = fw.row_kind[i] == RowKind::kFlight;
    fw.windows.push_back({t[i], t[j - 1], in ? "flight" : "excluded", in ? "inside --from/--to" : "outside --from/--to"});
    i = j;
  }
  return fw;
}

std::vector<std::string> PhaseLabels(const logs::FlightLog& log, const FlightWindows& windows, double min_segment_s) {
  const FlightWindows& fw = windows;
  const size_t n = log.rows();
  std::vector<std::string> ph(n, "unknown");
  if (n == 0 || !log.Has("t_s")) return ph;
  const auto& t = log.Column("t_s");
  const bool has_pos = log.Has("pos_D_m");
  const bool has_vel = log.Has("vel_N_mps") && log.Has("vel_E_mps") && log.Has("vel_D_mps");
  const std::vector<double>* alt = has_pos ? &log.Column("pos_D_m") : Col(log, "baro_alt_m");
  const double sign = has_pos ? -1.0 : 1.0;  // height up
  constexpr double kNearGround_m = 2.0, kVertical_mps = 0.5, kCruise_mps = 1.0, kClimbing_mps = 0.1;
  double h_ground = kNaN;
  // First finite height: the ground level until a ground row says otherwise.
  for (size_t i = 0; alt && i < n && std::isnan(h_ground); ++i) {
    if (std::isfinite((*alt)[i])) h_ground = sign * (*alt)[i];
  }
  for (size_t i = 0; i < n; ++i) {
    const RowKind k = i < fw.row_kind.size() ? fw.row_kind[i] : RowKind::kFlight;
    if (k == RowKind::kExcluded) {
      ph[i] = "excluded";
      continue;
    }
    const double h_now = alt ? sign * (*alt)[i] : kNaN;
    if (k == RowKind::kGround) {
      ph[i] = "ground";
      if (std::isfinite(h_now)) h_ground = h_now;
      continue;
    }
    if (!alt || !std::isfinite(h_now)) continue;
    const double h = h_now - h_ground;
    double vu = 0, vh = 0;
    if (has_vel) {
      vu = -log.Column("vel_D_mps")[i];
      vh = std::hypot(log.Column("vel_N_mps")[i], log.Column("vel_E_mps")[i]);
    } else if (i > 0 && i + 1 < n && t[i + 1] > t[i - 1]) {
      vu = sign * ((*alt)[i + 1] - (*alt)[i - 1]) / (t[i + 1] - t[i - 1]);
    }
    if (!std::isfinite(vu)) vu = 0;
    if (!std::isfinite(vh)) vh = 0;
    if (h < kNearGround_m && vu > kClimbing_mps) ph[i] = "takeoff";
    else if (h < kNearGround_m && vu < -kClimbing_mps) ph[i] = "landing";
    else if (vu > kVertical_mps) ph[i] = "climb";
    else if (vu < -kVertical_mps) ph[i] = "descent";
    else if (vh > kCruise_mps) ph[i] = "cruise";
    else ph[i] = "hover";
  }
  return MergeShortSegments(t, ph, min_segment_s, {"excluded", "ground"});
}

}  // namespace hexsim::realdata
