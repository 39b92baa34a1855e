// PX4 rotor order and airframe parameters (px4_frame.h).
#include "hexsim/bridge/px4_frame.h"

#include <algorithm>
#include <cmath>

#include <Eigen/LU>
#include <fmt/format.h>

#include "hexsim/bridge/sim_messages.h"
#include "hexsim/common/rotation.h"
#include "hexsim/vehicle/powertrain.h"

namespace hexsim::bridge {

namespace {

struct Slot {
  double angle_deg;  // from the nose, positive towards the right (atan2(y, x) in FRD)
  int spin;          // +1 CCW seen from above (hexsim's and PX4's KM > 0)
};
const std::vector<Slot> kQuadX = {{45, 1}, {-135, 1}, {-45, -1}, {135, -1}};
const std::vector<Slot> kHexX = {{90, -1}, {-90, 1}, {-30, -1}, {150, 1}, {30, 1}, {-150, -1}};
constexpr double kAngleToleranceDeg = 10.0;

double WrapDeg(double a) {
  while (a > 180.0) a -= 360.0;
  while (a <= -180.0) a += 360.0;
  return a;
}

// PX4's magnetometers in SITL (simulator_mavlink/SimulatorMavlink.hpp: PX4Magnetometer{197388},
// {197644}; HIL_SENSOR id 0 and 1).
constexpr int kPx4SimMagIds[2] = {197388, 197644};

}  // namespace

Result<Px4RotorMap> MapPx4Rotors(const vehicle::VehicleParams& v) {
  const size_t n = v.rotors.size();
  if (n != 4 && n != 6) {
    return Status::BadInput(fmt::format("{}: rotors: PX4's quad-X or hex-X needs 4 or 6 rotors (got {})", v.name, n));
  }
  Px4RotorMap map;
  map.frame = n == 4 ? "quad_x" : "hex_x";
  const std::vector<Slot>& slots = n == 4 ? kQuadX : kHexX;
  std::vector<bool> used(n, false);
  for (const Slot& s : slots) {
    bool found = false;
    for (size_t r = 0; r < n && !found; ++r) {
      const auto& p = v.rotors[r].position_B_m;
      const double a = std::atan2(p.y(), p.x()) * 180.0 / kPi;
      if (!used[r] && v.rotors[r].spin == s.spin && std::abs(WrapDeg(a - s.angle_deg)) <= kAngleToleranceDeg) {
        used[r] = true;
        map.rotor.push_back(r);
        found = true;
      }
    }
    if (!found) {
      return Status::BadInput(fmt::format("{}: rotors: no rotor at {} deg spinning {} for PX4's {} (motor {})", v.name,
                                          s.angle_deg, s.spin > 0 ? "CCW" : "CW", map.frame, map.rotor.size() + 1));
    }
  }
  return map;
}

void CommandsFromPx4Outputs(const Px4RotorMap& map, const float* controls, size_t n_controls,
                            std::vector<double>* commands) {
  for (size_t i = 0; i < map.rotor.size(); ++i) {
    const double c = i < n_controls ? static_cast<double>(controls[i]) : 0.0;
    (*commands)[map.rotor[i]] = std::isfinite(c) ? std::clamp(c, 0.0, 1.0) : 0.0;
  }
}

Result<std::string> Px4AirframeParams(const vehicle::VehicleParams& v) {
  auto map = MapPx4Rotors(v);
  if (!map.ok()) return map.status();
  const double V = v.battery.OpenCircuitVoltage_V(v.battery.initial_soc);
  std::string out;
  auto set = [&out](const std::string& name, double value) {
    out += fmt::format("param set-default {} {}\n", name, value);
  };
  const size_t n = map->rotor.size();
  set("CA_AIRFRAME", 0);
  set("CA_ROTOR_COUNT", static_cast<double>(n));
  for (size_t i = 0; i < n; ++i) {
    const auto& r = v.rotors[map->rotor[i]];
    const double km = r.k_T_Nprps2 > 0 ? r.spin * r.k_Q_Nmprps2 / r.k_T_Nprps2 : 0.0;  // torque/thrust, m
    set(fmt::format("CA_ROTOR{}_PX", i), std::round(r.position_B_m.x() * 1e4) / 1e4);
    set(fmt::format("CA_ROTOR{}_PY", i), std::round(r.position_B_m.y() * 1e4) / 1e4);
    set(fmt::format("CA_ROTOR{}_PZ", i), std::round(r.position_B_m.z() * 1e4) / 1e4);
    set(fmt::format("CA_ROTOR{}_KM", i), std::round(km * 1e4) / 1e4);
  }
  for (size_t i = 0; i < n; ++i) set(fmt::format("PWM_MAIN_FUNC{}", i + 1), static_cast<double>(101 + i));
  // Hover: each rotor carries m*g/n at full charge.
  const double hover = vehicle::CommandForThrust(v, map->rotor[0], v.mass_kg * kGravity_mps2 / n, V);
  set("MPC_THR_HOVER", std::round(hover * 100.0) / 100.0);
  // THR_MDL_FAC: least squares of T(u)/T(1) - u = f*(u^2 - u) over u in [0.2, 1].
  const double t_full = vehicle::ThrustForCommand(v, map->rotor[0], 1.0, V);
  double num = 0.0, den = 0.0;
  for (double u = 0.2; u <= 1.0 + 1e-9; u += 0.05) {
    const double rel = vehicle::ThrustForCommand(v, map->rotor[0], u, V) / t_full;
    num += (rel - u) * (u * u - u);
    den += (u * u - u) * (u * u - u);
  }
  set("THR_MDL_FAC", std::round(std::clamp(den > 0 ? num / den : 1.0, 0.0, 1.0) * 100.0) / 100.0);
  for (size_t c = 0; c < std::min<size_t>(2, v.compasses.size()); ++c) {
    const auto& e = v.compasses[c].error;
    const Eigen::Matrix3d S = (e.scale * e.soft_iron).inverse();
    const Eigen::Matrix3d Ss = 0.5 * (S + S.transpose());  // PX4's scale matrix is symmetric
    const std::string p = fmt::format("CAL_MAG{}_", c);
    set(p + "ID", kPx4SimMagIds[c]);
    set(p + "PRIO", c == 0 ? 75 : 50);
    const char* axes = "XYZ";
    for (int a = 0; a < 3; ++a) set(p + axes[a] + "OFF", std::round(e.hard_iron_uT(a) * kGaussPerUt * 1e5) / 1e5);
    for (int a = 0; a < 3; ++a) set(p + axes[a] + "SCALE", std::round(Ss(a, a) * 1e4) / 1e4);
    set(p + "XODIAG", std::round(Ss(0, 1) * 1e4) / 1e4);
    set(p + "YODIAG", std::round(Ss(0, 2) * 1e4) / 1e4);
    set(p + "ZODIAG", std::round(Ss(1, 2) * 1e4) / 1e4);
  }
  set("SIM_BAT_ENABLE", 0);
  return out;
}

}  // namespace hexsim::bridge
