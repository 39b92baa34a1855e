// Frame of a log and the default base vehicle of a frame class.
#include <algorithm>
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "hexsim/common/atomic_file.h"
#include "hexsim/common/paths.h"
#include "hexsim/common/rotation.h"
#include "hexsim/identify/identify.h"
#include "hexsim/vehicle/vehicle_io.h"
#include "samples.h"

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

namespace internal {

// Spins and positions in motor-number order. A PX4 log with the control allocator's geometry
// (CA_ROTORn_PX/PY/KM) gives its own; an autopilot log otherwise numbers its motors as its frame's
// table (ArduPilot AP_MotorsMatrix; PX4's quad and hex X mixers number them the same way); a hexsim
// log numbers them as its vehicle file, whose frame class the base shares.
Status ChooseLayout(const logs::FlightLog& log, const vehicle::VehicleParams& base,
                    const std::vector<FrameRotor>& table, IdentifyResult* res) {
  const std::string name = log.meta.value("source", std::string("log"));
  const std::string format = log.meta.value("format", std::string());
  const bool autopilot = format == "ardupilot-dataflash" || format == "px4-ulog";
  double arm_m = 0.0;  // the base's mean arm: the table gives angles only
  for (const auto& r : base.rotors) arm_m += r.position_B_m.head<2>().norm() / static_cast<double>(base.rotors.size());
  const nlohmann::json* params = log.meta.contains("params") && log.meta["params"].is_object() ? &log.meta["params"] : nullptr;
  auto param = [&](const std::string& k) {
    return params && params->contains(k) && (*params)[k].is_number() ? (*params)[k].get<double>() : std::nan("");
  };
  res->spins.clear();
  res->rotor_xy_m.clear();
  bool px4_geometry = format == "px4-ulog";
  for (size_t m = 0; px4_geometry && m < res->motors; ++m) {
    px4_geometry = std::isfinite(param(fmt::format("CA_ROTOR{}_PX", m))) && std::isfinite(param(fmt::format("CA_ROTOR{}_PY", m))) &&
                   param(fmt::format("CA_ROTOR{}_KM", m)) != 0.0 && std::isfinite(param(fmt::format("CA_ROTOR{}_KM", m)));
  }
  for (size_t m = 0; m < res->motors; ++m) {
    if (px4_geometry) {
      res->spins.push_back(param(fmt::format("CA_ROTOR{}_KM", m)) > 0 ? 1 : -1);
      res->rotor_xy_m.push_back({param(fmt::format("CA_ROTOR{}_PX", m)), param(fmt::format("CA_ROTOR{}_PY", m))});
    } else if (autopilot && !table.empty()) {
      const double a = table[m].angle_deg * kPi / 180.0;  // clockwise from the nose: +y is right
      res->spins.push_back(table[m].spin);
      res->rotor_xy_m.push_back({arm_m * std::cos(a), arm_m * std::sin(a)});
    } else if (m < base.rotors.size()) {
      res->spins.push_back(base.rotors[m].spin);
      res->rotor_xy_m.push_back({base.rotors[m].position_B_m.x(), base.rotors[m].position_B_m.y()});
    } else {
      return Status::BadInput(fmt::format("{}: frame '{}' has {} motors, the base vehicle '{}' {}", name, res->frame,
                                          res->motors, base.name, base.rotors.size()));
    }
  }
  res->layout_source = px4_geometry ? "the log's CA_ROTORn_PX/PY/KM (PX4 control allocation)"
                       : autopilot && !table.empty()
                           ? fmt::format("the {} motor table (ArduPilot AP_MotorsMatrix order) at the base's arm {:.3g} m", res->frame, arm_m)
                           : "the base vehicle's rotors";
  // Differs from the base: another count, a spin, or a rotor more than 10 % of the arm (or 5 cm) away.
  res->layout_from_log = res->motors != base.rotors.size();
  for (size_t m = 0; !res->layout_from_log && m < res->motors; ++m) {
    const auto& r = base.rotors[m];
    const double d = std::hypot(res->rotor_xy_m[m][0] - r.position_B_m.x(), res->rotor_xy_m[m][1] - r.position_B_m.y());
    res->layout_from_log = res->spins[m] != r.spin || d > std::max(0.05, 0.1 * arm_m);
  }
  return Status::Ok();
}

}  // namespace internal

std::string FrameOfLog(const logs::FlightLog& log, std::string* source) {
  const double fc = ParamOr(log, "FRAME_CLASS", NAN), ft = ParamOr(log, "FRAME_TYPE", NAN);
  std::string unnamed;  // what the parameters said that the motor tables do not name
  if (std::isfinite(fc) && std::isfinite(ft)) {
    std::string name = internal::FrameNameFor(static_cast<int>(fc), static_cast<int>(ft));
    if (!name.empty()) {
      *source = fmt::format("FRAME_CLASS {} / FRAME_TYPE {}", static_cast<int>(fc), static_cast<int>(ft));
      return name;
    }
    unnamed = fmt::format("FRAME_CLASS {} / FRAME_TYPE {} is not in the motor tables", static_cast<int>(fc),
                          static_cast<int>(ft));
  }
  // Before 3.5 the firmware build fixed the class and FRAME the layout: 0 plus, 1 X, 2 V, 3 H (then
  // V-tail, A-tail, Y6 ...).
  const double frame = ParamOr(log, "FRAME", NAN);
  const int motors = log.meta.value("motor_count", 0);
  const std::string motors_from = log.meta.value("motor_count_source", std::string("meta"));
  static const char* const kOldLayouts[] = {"plus", "x", "v", "h"};
  if (std::isfinite(frame) && unnamed.empty()) {
    const int f = static_cast<int>(frame);
    std::string name = f >= 0 && f < 4 && !ClassName(motors).empty() ? ClassName(motors) + "-" + kOldLayouts[f] : "";
    if (!name.empty() && !internal::FrameRotors(name).empty()) {
      *source = fmt::format("FRAME {} and {} motors ({})", f, motors, motors_from);
      return name;
    }
    unnamed = fmt::format("FRAME {} with {} motors is not in the motor tables", f, motors);
  }
  // A frame the tables do not name: its motor count, X layout assumed.
  const int active = ActiveMotorOutputs(log);
  const int n = !ClassName(motors).empty() ? motors : active;
  if (!ClassName(n).empty()) {
    *source = (unnamed.empty() ? std::string("no frame parameters") : unnamed) +
              fmt::format(": {} motors ({}), X layout assumed", n,
                          n == motors ? motors_from : fmt::format("{} active motor outputs", active));
    return ClassName(n) + "-x";
  }
  const std::string counts = (motors > 0 ? fmt::format("{} motors ({})", motors, motors_from) : "no motor count") +
                             fmt::format(", {} active motor outputs", active);
  *source = unnamed.empty() ? "no frame parameters, and " + counts + ": not a quad, hex or octo"
                            : unnamed + ", and the motor count is not a quad, hex or octo (" + counts + ")";
  return "";
}

std::vector<std::string> FrameNames() {
  return {"quad-x",  "quad-plus", "quad-v",   "quad-h",    "quad-plus-rev", "quad-bf-x", "quad-dji-x", "quad-cw-x",
          "quad-bf-x-rev", "hex-x", "hex-plus", "hex-h", "hex-dji-x", "hex-cw-x", "octo-x"};
}

Result<BaseVehicle> ChooseBaseVehicle(const logs::FlightLog& log, const std::string& name, const std::string& frame,
                                      const std::string& log_name, const std::string& what_to_give) {
  BaseVehicle b;
  std::string base_name = name;
  if (base_name.empty()) {
    b.frame_source = "--frame";
    b.frame = frame.empty() || frame == "auto" ? FrameOfLog(log, &b.frame_source) : frame;
    base_name = DefaultBaseFor(b.frame);
    if (base_name.empty()) {
      return Status::BadInput(b.frame.empty()
                                  ? fmt::format("{}: frame: not determined ({}); {}", log_name, b.frame_source, what_to_give)
                                  : fmt::format("{}: frame: no shipped vehicle for '{}' ({}); {}", log_name, b.frame,
                                                b.frame_source, what_to_give));
    }
  }
  auto path = ResolveWorldFile("vehicles", base_name);
  if (!path.ok()) return path.status();
  auto text = ReadFile(*path);
  if (!text.ok()) return text.status();
  auto params = vehicle::LoadVehicleFile(*path);
  if (!params.ok()) return params.status();
  b.params = std::move(params).value();
  b.yaml = std::move(text).value();
  b.path = *path;
  return b;
}

std::string DefaultBaseFor(const std::string& frame) {
  if (frame.rfind("quad", 0) == 0) return "quad_x";
  if (frame.rfind("hex", 0) == 0) return "default_hex";
  if (frame.rfind("octo", 0) == 0) return "octo_x";
  return "";
}

}  // namespace hexsim::identify
