// Frame of a log and the default base vehicle of a frame class.
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "hexsim/identify/identify.h"

namespace hexsim::identify {
namespace {

double ParamOr(const logs::FlightLog& log, const char* name, double fallback) {
  const auto& m = log.meta;
  if (m.contains("params") && m["params"].is_object() && m["params"].contains(name) && m["params"][name].is_number()) {
    return m["params"][name].get<double>();
  }
  return fallback;
}

std::string ClassName(int motors) {
  switch (motors) {
    case 4: return "quad";
    case 6: return "hex";
    case 8: return "octo";
    default: return "";
  }
}

// Motor outputs that move in the log (rcou stream, else the table's motor_i_u columns).
int ActiveMotorOutputs(const logs::FlightLog& log) {
  const logs::FlightLog rcou = logs::StreamAtOwnRate(log, "rcou");
  int n = 0;
  for (int m = 1; m <= 12; ++m) {
    const std::string c = fmt::format("motor_{}_u", m);
    if (!rcou.Has(c)) break;
    bool moves = false;
    for (double x : rcou.Column(c)) moves = moves || (std::isfinite(x) && x > 0);
    if (!moves) break;
    n = m;
  }
  return n;
}

}  // namespace

std::string FrameOfLog(const logs::FlightLog& log, std::string* source) {
  const double fc = ParamOr(log, "FRAME_CLASS", NAN), ft = ParamOr(log, "FRAME_TYPE", NAN);
  if (std::isfinite(fc)) {
    static const int kMotors[] = {0, 4, 6, 8};  // FRAME_CLASS 1 quad, 2 hexa, 3 octa
    const int c = static_cast<int>(fc);
    const std::string cls = c >= 1 && c <= 3 ? ClassName(kMotors[c]) : "";
    if (!cls.empty() && std::isfinite(ft) && (ft == 0 || ft == 1)) {
      *source = fmt::format("FRAME_CLASS {} / FRAME_TYPE {}", c, static_cast<int>(ft));
      return cls + (ft == 0 ? "-plus" : "-x");
    }
  }
  const double frame = ParamOr(log, "FRAME", NAN);  // 3.3: 0 plus, 1 X
  const int motors = log.meta.value("motor_count", 0);
  if (std::isfinite(frame) && (frame == 0 || frame == 1) && !ClassName(motors).empty()) {
    *source = fmt::format("FRAME {} and {} motors ({})", static_cast<int>(frame), motors,
                          log.meta.value("motor_count_source", std::string("meta")));
    return ClassName(motors) + (frame == 0 ? "-plus" : "-x");
  }
  const int active = ActiveMotorOutputs(log);
  if (!ClassName(active).empty()) {
    *source = fmt::format("{} active motor outputs (X layout assumed)", active);
    return ClassName(active) + "-x";
  }
  *source = "not determined";
  return "";
}

std::string DefaultBaseFor(const std::string& frame) {
  if (frame.rfind("quad", 0) == 0) return "quad_x";
  if (frame.rfind("hex", 0) == 0) return "default_hex";
  return "";
}

}  // namespace hexsim::identify
