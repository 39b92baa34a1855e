#include "hexsim/logs/current_check.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <fmt/format.h>

namespace hexsim::logs {
namespace {

constexpr double kControlFullScale = 1000.0;  // control_u: 0..1000
// Cell voltages ArduPilot's documentation recommends for its battery scaling parameters.
constexpr double kBatVoltMaxPerCell_V = 4.2;  // MOT_BAT_VOLT_MAX: "4.2 × cell count"
constexpr double kBatVoltMinPerCell_V = 3.3;  // MOT_BAT_VOLT_MIN: "3.3 × cell count"
constexpr int kMaxCells = 24;                 // no multirotor pack has more (a 100 V class system)
constexpr char kUnusable[] = "current sensor unusable: units or no power monitor";
constexpr char kNotFlown[] = "current sensor unusable: not checked in flight";

double Median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

double MetaParam(const FlightLog& log, const char* name) {
  const auto& m = log.meta;
  if (!m.is_object() || !m.contains("params") || !m["params"].is_object()) return std::nan("");
  const auto it = m["params"].find(name);
  return it != m["params"].end() && it->is_number() ? it->get<double>() : std::nan("");
}

// Cells from the parameters: PX4's count itself, else ArduPilot's voltage scaling limits.
int CellsFromParams(const FlightLog& log, std::string* source) {
  for (const char* name : {"BAT1_N_CELLS", "BAT_N_CELLS"}) {
    const double n = MetaParam(log, name);
    if (n >= 1 && n <= kMaxCells) {
      *source = name;
      return static_cast<int>(std::lround(n));
    }
  }
  const std::pair<const char*, double> kScaled[] = {{"MOT_BAT_VOLT_MAX", kBatVoltMaxPerCell_V},
                                                    {"MOT_BAT_VOLT_MIN", kBatVoltMinPerCell_V}};
  for (const auto& [name, per_cell_V] : kScaled) {
    const double v = MetaParam(log, name);
    const long n = std::isfinite(v) ? std::lround(v / per_cell_V) : 0;
    if (n >= 1 && n <= kMaxCells) {
      *source = fmt::format("{} {:g} V / {:g} V per cell", name, v, per_cell_V);
      return static_cast<int>(n);
    }
  }
  return 0;
}

int MotorsOf(const FlightLog& log) {
  int n = log.meta.is_object() ? log.meta.value("motor_count", 0) : 0;
  if (n <= 0) {
    while (log.Has(fmt::format("motor_{}_u", n + 1))) ++n;
  }
  return n;
}

// Rows where the vehicle flies (see the header), or empty when the log cannot tell.
std::vector<size_t> FlightRows(const FlightLog& log, int motors) {
  std::vector<const std::vector<double>*> outputs;
  for (int i = 1; i <= motors; ++i) {
    const std::string c = fmt::format("motor_{}_u", i);
    if (log.Has(c)) outputs.push_back(&log.Column(c));
  }
  const std::vector<double>* control = log.Has("control_u") ? &log.Column("control_u") : nullptr;
  const std::vector<double>* armed = log.Has("armed") ? &log.Column("armed") : nullptr;
  std::vector<size_t> rows;
  if (outputs.empty() && control == nullptr) return rows;
  for (size_t r = 0; r < log.rows(); ++r) {
    if (armed != nullptr && (*armed)[r] == 0.0) continue;
    double level = std::nan("");
    if (!outputs.empty()) {
      double sum = 0.0;
      size_t k = 0;
      for (const auto* col : outputs) {
        if (std::isfinite((*col)[r])) {
          sum += (*col)[r];
          ++k;
        }
      }
      if (k > 0) level = sum / static_cast<double>(k);
    } else {
      level = (*control)[r] / kControlFullScale;
    }
    if (level >= kFlyingMotorOutput) rows.push_back(r);
  }
  return rows;
}

// Whether the log can say when the vehicle flies: motor outputs or control_u with a value.
bool LogsTheThrottle(const FlightLog& log, int motors) {
  auto has_value = [&log](const std::string& c) {
    if (!log.Has(c)) return false;
    const std::vector<double>& v = log.Column(c);
    return std::any_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
  };
  for (int i = 1; i <= motors; ++i) {
    if (has_value(fmt::format("motor_{}_u", i))) return true;
  }
  return has_value("control_u");
}

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(q * static_cast<double>(v.size() - 1))];
}

// The height span (5th..95th percentile) over `rows` and the column it came from; NaN when the log
// has no height at ten of them.

bool HasMeasured(const FlightLog& log, const std::string& column) {
  if (!log.Has(column)) return false;
  const std::vector<double>& v = log.Column(column);
  return std::any_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}

std::vector<double> ValuesAt(const std::vector<double>& column, const std::vector<size_t>& rows) {
  std::vector<double> v;
  v.reserve(rows.size());
  for (size_t r : rows) {
    if (std::isfinite(column[r])) v.push_back(column[r]);
  }
  return v;
}

}  // namespace

double LoggedHeightSpan_m(const FlightLog& log, const std::vector<size_t>& rows, std::string* column) {
  constexpr size_t kMinHeightSamples = 10;
  for (const char* c : {"baro_alt_m", "pos_D_m"}) {
    if (!log.Has(c)) continue;
    std::vector<double> h;
    for (size_t r : rows) {
      if (std::isfinite(log.Column(c)[r])) h.push_back(log.Column(c)[r]);
    }
    if (h.size() < kMinHeightSamples) continue;
    *column = c;
    return Percentile(h, 0.95) - Percentile(h, 0.05);
  }
  return std::numeric_limits<double>::quiet_NaN();
}

CurrentSensorCheck CheckCurrentSensor(const FlightLog& log) {
  CurrentSensorCheck c;
  c.motors = MotorsOf(log);
  c.cells = CellsFromParams(log, &c.cells_source);
  std::vector<size_t> flight = FlightRows(log, c.motors);
  std::string height_column, ground_run;
  if (const double span_m = LoggedHeightSpan_m(log, flight, &height_column); span_m < kMinFlightClimb_m) {
    ground_run = fmt::format("current not checked: the motors ran at flight output for {} rows but {} spans {:.2g} m "
                             "over them (a flight climbs {:g} m or more): a run on the ground",
                             flight.size(), height_column, span_m, kMinFlightClimb_m);
    flight.clear();
  }
  c.flight_rows = flight.size();
  std::vector<std::string> reasons;
  if (!HasMeasured(log, "current_A")) {  // absent, or "not available" in every sample
    c.usable = false;
    c.why = std::string(kUnusable) + ": the log has no current";
    return c;
  }
  const std::vector<double> current = ValuesAt(log.Column("current_A"), flight);
  const int per = std::max(c.motors, kMinMultirotorMotors);
  if (!current.empty()) {
    c.checked = true;
    c.median_current_A = Median(current);
    if (!(c.median_current_A >= kMinFlightCurrentPerMotor_A * per)) {
      reasons.push_back(fmt::format("flight median {:.3g} A over {} motors{} ({:.3g} A per motor, a flying motor draws "
                                    "at least {:g} A)",
                                    c.median_current_A + 0.0, per,
                                    c.motors <= 0                         ? " (count unknown: at least 3)"
                                    : c.motors < kMinMultirotorMotors ? fmt::format(" (the log says {}: a multirotor has at least 3)", c.motors)
                                                                      : std::string(),
                                    c.median_current_A / per + 0.0, kMinFlightCurrentPerMotor_A));
    }
  } else if (!ground_run.empty()) {
    c.note = ground_run;
  } else {
    c.note = flight.empty() ? fmt::format("current not checked: no flight rows (mean motor output never {:g} or more "
                                          "while armed, or no motor outputs)",
                                          kFlyingMotorOutput)
                            : std::string("current not checked: no current logged in flight");
  }
  // A log whose throttle shows the motors never carried the vehicle (never at flight output while
  // armed, or at flight output without climbing) leaves its current unverified: the flight rule is
  // the only check of its scale (a x0.01 unit error reads like a props-off motor's no-load current),
  // and what it measured is no flight current (props off, a motor draws its no-load current; a
  // 12S quad's ground run at output 0.4-0.9 drew 0.66 A per motor). No current-based fit then.
  const bool not_flown = !c.checked && (!ground_run.empty() || (flight.empty() && LogsTheThrottle(log, c.motors)));
  if (log.Has("voltage_V")) {
    std::vector<double> voltage = ValuesAt(log.Column("voltage_V"), flight);
    if (voltage.empty()) {
      std::vector<size_t> all(log.rows());
      for (size_t r = 0; r < all.size(); ++r) all[r] = r;
      voltage = ValuesAt(log.Column("voltage_V"), all);
    }
    c.median_voltage_V = Median(voltage);
    if (std::isfinite(c.median_voltage_V)) {
      const double limit_V = c.cells > 0 ? kMinCellVoltage_V * c.cells : kMinPackVoltageUnknownCells_V;
      if (c.median_voltage_V < limit_V) {
        reasons.push_back(c.cells > 0 ? fmt::format("median voltage {:.3g} V over {} cells ({}: {:.3g} V per cell, under "
                                                    "{:g} V)",
                                                    c.median_voltage_V, c.cells, c.cells_source,
                                                    c.median_voltage_V / c.cells, kMinCellVoltage_V)
                                      : fmt::format("median voltage {:.3g} V (cell count unknown: under {:g} V)",
                                                    c.median_voltage_V, kMinPackVoltageUnknownCells_V));
      }
    }
  }
  if (!reasons.empty()) {
    c.usable = false;
    c.why = kUnusable;
    for (size_t i = 0; i < reasons.size(); ++i) c.why += (i == 0 ? ": " : "; ") + reasons[i];
    const double monitor = MetaParam(log, "BATT_MONITOR");
    if (monitor == 0.0) c.why += "; BATT_MONITOR 0 (no power monitor)";
  } else if (not_flown) {
    c.usable = false;
    c.why = std::string(kNotFlown) + ": " + c.note.substr(c.note.find(": ") + 2) +
            " (the current is judged where the motors carry the vehicle; no current-based fit without it)";
  }
  return c;
}

void WriteCurrentCheck(const CurrentSensorCheck& c, nlohmann::json* meta) {
  auto num = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); };
  (*meta)["current_usable"] = c.usable;
  (*meta)["current_unusable_why"] = c.why;
  (*meta)["current_check"] = {
      {"checked", c.checked},
      {"flight_rows", c.flight_rows},
      {"median_current_A", num(c.median_current_A)},
      {"median_voltage_V", num(c.median_voltage_V)},
      {"motors", c.motors},
      {"cells", c.cells},
      {"cells_source", c.cells_source},
      {"note", c.note},
      {"rule", fmt::format("unusable when the flight median current is under {:g} A per motor (flight: armed, mean "
                           "motor output >= {:g}), or the median voltage under {:g} V per cell ({:g} V when the cell "
                           "count is unknown)",
                           kMinFlightCurrentPerMotor_A, kFlyingMotorOutput, kMinCellVoltage_V,
                           kMinPackVoltageUnknownCells_V)}};
}

CurrentSensorCheck CurrentSensorOf(const FlightLog& log) {
  const auto& m = log.meta;
  if (!m.is_object() || !m.contains("current_usable") || !m["current_usable"].is_boolean()) {
    return CheckCurrentSensor(log);
  }
  CurrentSensorCheck c;
  c.usable = m["current_usable"].get<bool>();
  c.why = m.value("current_unusable_why", std::string());
  if (!c.usable && c.why.empty()) c.why = kUnusable;
  if (m.contains("current_check") && m["current_check"].is_object()) {
    const auto& k = m["current_check"];
    auto num = [&k](const char* key) {
      return k.contains(key) && k[key].is_number() ? k[key].get<double>() : std::nan("");
    };
    c.checked = k.value("checked", false);
    c.flight_rows = k.value("flight_rows", size_t{0});
    c.median_current_A = num("median_current_A");
    c.median_voltage_V = num("median_voltage_V");
    c.motors = k.value("motors", 0);
    c.cells = k.value("cells", 0);
    c.cells_source = k.value("cells_source", std::string());
    c.note = k.value("note", std::string());
  }
  return c;
}

std::string CurrentCheckLine(const CurrentSensorCheck& c) {
  if (!c.usable) return "current: " + c.why;
  std::string s = "current: usable";
  if (c.checked) {
    // + 0.0: a median of -0 A prints as 0 A
    s += c.motors > 0 ? fmt::format(" (flight median {:.3g} A over {} motors", c.median_current_A + 0.0, c.motors)
                      : fmt::format(" (flight median {:.3g} A, motor count unknown", c.median_current_A + 0.0);
    if (std::isfinite(c.median_voltage_V)) s += fmt::format(", {:.3g} V", c.median_voltage_V);
    s += ")";
  }
  if (!c.note.empty()) s += "; " + c.note;
  return s;
}

}  // namespace hexsim::logs
