// The identified vehicle against another (gap diagnose --sim) and the held-out log (without --sim).
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "hexsim/common/rotation.h"
#include "hexsim/identify/identify.h"
#include "hexsim/vehicle/powertrain.h"

namespace hexsim::identify {
namespace {

bool InFitBlock(const IdentifyResult& r, double t) {
  for (const BlockSpan& b : r.blocks) {
    if (t >= b.start_s && t <= b.end_s && std::find(r.fit_blocks.begin(), r.fit_blocks.end(), b.block) != r.fit_blocks.end()) {
      return true;
    }
  }
  return false;
}

bool IsMeasuredColumn(const std::string& c) {
  if (c.rfind("gyro_", 0) == 0 || c.rfind("accel_", 0) == 0) return true;
  if (c.rfind("mag", 0) != 0) return false;
  return c.size() > 5 && (c.compare(c.size() - 5, 5, "_x_uT") == 0 || c.compare(c.size() - 5, 5, "_y_uT") == 0 ||
                          c.compare(c.size() - 5, 5, "_z_uT") == 0) &&
         c.find("_mot_") == std::string::npos;
}

void EmptyFitBlocks(const IdentifyResult& r, logs::FlightLog* t) {
  if (!t->Has("t_s")) return;
  const std::vector<double> time = t->Column("t_s");
  std::vector<size_t> cols;
  for (size_t c = 0; c < t->columns().size(); ++c) {
    if (IsMeasuredColumn(t->columns()[c])) cols.push_back(c);
  }
  for (size_t row = 0; row < t->rows(); ++row) {
    if (!InFitBlock(r, time[row])) continue;
    for (size_t c : cols) t->MutableColumn(c)[row] = logs::kMissing;
  }
}

}  // namespace

logs::FlightLog HeldOutLog(const logs::FlightLog& log, const IdentifyResult& r) {
  logs::FlightLog out = log;
  EmptyFitBlocks(r, &out);
  for (const std::string& name : log.stream_names()) {
    logs::FlightLog s = *log.Stream(name);
    EmptyFitBlocks(r, &s);
    out.SetStream(name, std::move(s));
  }
  out.meta["identify_heldout"] = "measured sensor columns emptied inside the blocks the vehicle was identified on";
  return out;
}

nlohmann::json DistanceFromVehicle(const IdentifyResult& r, const vehicle::VehicleParams& v,
                                   std::vector<std::string>* lines) {
  nlohmann::json j = nlohmann::json::object();
  if (v.rotors.empty()) return j;
  const double m = v.mass_kg + v.payload.mass_kg;
  const double T = m * kGravity_mps2 / static_cast<double>(v.rotors.size());
  const double V = r.v_ref_V > 0 ? r.v_ref_V : v.battery.OpenCircuitVoltage_V(v.battery.initial_soc);
  const auto& r0 = v.rotors.front();
  const double omega_h = std::sqrt(T / r0.k_T_Nprps2);
  const double Kt = v.motor.Kt_Nm_per_A();
  const double tau = v.motor.winding_resistance_ohm > 0
                         ? v.RotorInertia_kgm2(0) / (Kt * Kt / v.motor.winding_resistance_ohm + 2 * r0.k_Q_Nmprps2 * omega_h)
                         : std::nan("");
  const std::pair<const char*, double> kVehicle[] = {
      {"hover_output", vehicle::CommandForThrust(v, 0, T, V)},
      {"thrust_scale", 1.0},
      {"motor_time_constant_s", tau},
      {"yaw_torque_coefficient_m", r0.k_Q_Nmprps2 / r0.k_T_Nprps2},
      {"linear_drag_per_mass_1ps", v.drag.linear_Nspm.x() / m},
      {"battery_resistance_ohm", v.battery.internal_resistance_ohm},
  };
  for (const auto& [k, value] : kVehicle) {
    auto it = r.params.find(k);
    if (it == r.params.end()) continue;
    const Param& p = it->second;
    if (!std::isfinite(p.value)) {  // not identified (too few samples, or no data for it): no comparison
      j[k] = {{"identified", nullptr}, {"vehicle", value}, {"unit", p.unit}, {"source", p.source}};
      if (lines) lines->push_back(fmt::format("{}: not identified from this log ({} in {})", k, value, v.name));
      continue;
    }
    const bool inside = value >= p.ci95[0] && value <= p.ci95[1];
    j[k] = {{"identified", p.value}, {"ci95", {p.ci95[0], p.ci95[1]}}, {"vehicle", value}, {"unit", p.unit},
            {"vehicle_inside_ci95", inside}, {"source", p.source}};
    if (lines) {
      lines->push_back(fmt::format("{} {:.4g} [{:.4g}, {:.4g}] {} in the log vs {:.4g} in {}{}", k, p.value, p.ci95[0],
                                   p.ci95[1], p.unit, value, v.name, inside ? " (inside the interval)" : ""));
    }
  }
  return j;
}

}  // namespace hexsim::identify
