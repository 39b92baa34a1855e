// The identified vehicle: the base with the fitted values applied, as parameters and as YAML.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <system_error>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "hexsim/common/atomic_file.h"
#include "hexsim/common/plausibility.h"
#include "hexsim/common/rotation.h"
#include "hexsim/common/yaml_reader.h"
#include "hexsim/control/control_io.h"
#include "hexsim/control/controller.h"
#include "hexsim/identify/identify.h"
#include "hexsim/vehicle/powertrain.h"

namespace hexsim::identify {
namespace {

// The fitted value of a usable parameter (fitted and inside its range), else nullopt.
std::optional<double> Fitted(const IdentifyResult& r, const std::string& k) {
  auto it = r.params.find(k);
  if (it == r.params.end() || !it->second.applied || !std::isfinite(it->second.value)) return std::nullopt;
  return it->second.value;
}

// Rotor inertia that gives the rotor speed the time constant τ at hover:
// τ = J/(K_t²/R + 2·k_Q·ω_h), k_T·ω_h² = m·g/n.
double InertiaForTimeConstant(const vehicle::VehicleParams& v, double tau_s) {
  const auto& r = v.rotors.front();
  const double m = v.mass_kg + v.payload.mass_kg;
  const double omega_h = std::sqrt(m * kGravity_mps2 / (static_cast<double>(v.rotors.size()) * r.k_T_Nprps2));
  const double Kt = v.motor.Kt_Nm_per_A();
  return tau_s * (Kt * Kt / v.motor.winding_resistance_ohm + 2.0 * r.k_Q_Nmprps2 * omega_h);
}

// State of charge at which the pack's open-circuit voltage is V (inverse of the per-cell table).
double SocForOcv(const vehicle::BatteryParams& b, double V) {
  const double cell = V / b.cells_series;
  const auto& s = b.ocv_soc;
  const auto& c = b.ocv_cell_V;
  if (cell <= c.front()) return s.front();
  for (size_t i = 1; i < c.size(); ++i) {
    if (cell <= c[i]) return s[i - 1] + (s[i] - s[i - 1]) * (cell - c[i - 1]) / (c[i] - c[i - 1]);
  }
  return s.back();
}

// Hover rotor time constant τ = J/(K_t²/R + 2·k_Q·ω_h) (0 when undefined).
double HoverTau_s(const vehicle::VehicleParams& v) {
  if (v.rotors.empty() || !(v.motor.winding_resistance_ohm > 0)) return 0.0;
  const auto& r = v.rotors.front();
  const double omega_h = std::sqrt((v.mass_kg + v.payload.mass_kg) * kGravity_mps2 /
                                   (static_cast<double>(v.rotors.size()) * r.k_T_Nprps2));
  const double Kt = v.motor.Kt_Nm_per_A();
  return v.RotorInertia_kgm2(0) / (Kt * Kt / v.motor.winding_resistance_ohm + 2.0 * r.k_Q_Nmprps2 * omega_h);
}

// The controller's gains act on accelerations (τ = J·α, a = thrust/m: see control/controller.h),
// so thrust and inertia ratios enter through the vehicle model, not the gains. A slower rotor
// (identified τ above the base's) is met by slowing the whole cascade by k = τ_base/τ: every loop's
// crossover scales with k (kp ×k, ki ×k², kd unchanged; rate, attitude, velocity and position), so
// each loop keeps its phase margin against the slower rotor (L = kp/(s(τs + 1)) time-scaled).
control::ControllerParams RescaledControl(const control::ControllerParams& c, double k) {
  control::ControllerParams o = c;
  auto pid = [k](control::PidGains* g) {
    g->kp *= k;
    g->ki *= k * k;
  };
  for (control::PidGains* g : {&o.rate_roll, &o.rate_pitch, &o.rate_yaw, &o.vel_xy, &o.vel_z}) pid(g);
  o.att_roll_kp *= k;
  o.att_pitch_kp *= k;
  o.att_yaw_kp *= k;
  o.pos_xy_kp *= k;
  o.pos_z_kp *= k;
  return o;
}

}  // namespace

vehicle::VehicleParams ApplyIdentified(const vehicle::VehicleParams& base, const IdentifyResult& r) {
  vehicle::VehicleParams v = base;
  const double m = base.mass_kg + base.payload.mass_kg;
  if (r.layout_from_log && !base.rotors.empty() && r.rotor_xy_m.size() == r.spins.size() && !r.spins.empty()) {
    // The log's motor order, spins and positions (each rotor otherwise as the base's, height kept).
    std::vector<vehicle::RotorParams> rotors;
    for (size_t i = 0; i < r.spins.size(); ++i) {
      vehicle::RotorParams rot = base.rotors[std::min(i, base.rotors.size() - 1)];
      rot.position_B_m.x() = r.rotor_xy_m[i][0];
      rot.position_B_m.y() = r.rotor_xy_m[i][1];
      rot.spin = r.spins[i];
      rotors.push_back(rot);
    }
    v.rotors = rotors;
  }
  if (auto s = Fitted(r, "thrust_scale")) {
    for (auto& rot : v.rotors) rot.k_T_Nprps2 *= *s;
  }
  if (auto q = Fitted(r, "yaw_torque_coefficient_m")) {
    for (auto& rot : v.rotors) rot.k_Q_Nmprps2 = *q * rot.k_T_Nprps2;
  }
  // k_Q changes the current a rotor draws at a given thrust, hence its hover command: scale k_T
  // again (with k_Q/k_T kept) until the vehicle hovers at the identified output on V_ref.
  if (auto u_h = Fitted(r, "hover_output"); u_h && r.v_ref_V > 0 && Fitted(r, "thrust_scale")) {
    const double T = m * kGravity_mps2 / static_cast<double>(v.rotors.size());
    auto cmd = [&](double s) {
      vehicle::VehicleParams w = v;
      for (auto& rot : w.rotors) {
        rot.k_T_Nprps2 *= s;
        rot.k_Q_Nmprps2 *= s;
      }
      return vehicle::CommandForThrust(w, 0, T, r.v_ref_V);
    };
    const plausibility::PhysicalRange* range = plausibility::FindRange("thrust_scale");  // the k_T factor's range
    double lo = range->lo, hi = range->hi;
    if (cmd(lo) >= *u_h && cmd(hi) <= *u_h) {
      for (int i = 0; i < 50; ++i) {
        const double mid = std::sqrt(lo * hi);
        (cmd(mid) > *u_h ? lo : hi) = mid;
      }
      for (auto& rot : v.rotors) {
        rot.k_T_Nprps2 *= std::sqrt(lo * hi);
        rot.k_Q_Nmprps2 *= std::sqrt(lo * hi);
      }
    }
  }
  if (auto tau = Fitted(r, "motor_time_constant_s"); tau && !v.rotors.empty() && v.motor.winding_resistance_ohm > 0) {
    v.motor.inertia_kgm2 = InertiaForTimeConstant(v, *tau);
    for (auto& rot : v.rotors) rot.inertia_kgm2 = 0.0;  // every rotor takes the motor's
  }
  if (auto d = Fitted(r, "linear_drag_per_mass_1ps")) v.drag.linear_Nspm.head<2>().setConstant(*d * m);
  if (auto d = Fitted(r, "quadratic_drag_per_mass_1pm")) v.drag.quadratic_Ns2pm2.head<2>().setConstant(*d * m);
  if (auto d = Fitted(r, "vertical_drag_per_mass_1ps")) v.drag.linear_Nspm.z() = *d * m;
  if (auto R = Fitted(r, "battery_resistance_ohm")) v.battery.internal_resistance_ohm = *R;
  if (auto V0 = Fitted(r, "battery_ocv_V")) {
    v.battery.cells_series = std::max(1, static_cast<int>(std::lround(*V0 / 3.8)));
    v.battery.initial_soc = SocForOcv(v.battery, *V0);
  }
  v.name = base.name + "_identified";
  return v;
}

Result<std::string> IdentifiedVehicleYaml(const std::string& base_yaml_text, const vehicle::VehicleParams& base,
                                          const IdentifyResult& r) {
  YAML::Node doc;
  try {
    doc = YAML::Load(base_yaml_text);
  } catch (const YAML::Exception& e) {
    return Status::BadInput(std::string("base vehicle: YAML: ") + e.what());
  }
  const vehicle::VehicleParams v = ApplyIdentified(base, r);
  auto vec3 = [](const Eigen::Vector3d& x) {
    YAML::Node n(YAML::NodeType::Sequence);
    for (int i = 0; i < 3; ++i) n.push_back(x(i));
    n.SetStyle(YAML::EmitterStyle::Flow);
    return n;
  };
  doc["name"] = v.name;
  YAML::Node rd = doc["rotor_defaults"];
  rd["k_T_Nprps2"] = v.rotors.front().k_T_Nprps2;
  rd["k_Q_Nmprps2"] = v.rotors.front().k_Q_Nmprps2;
  if (r.layout_from_log) {
    YAML::Node rotors(YAML::NodeType::Sequence);
    for (size_t i = 0; i < v.rotors.size(); ++i) {
      YAML::Node rot = i < doc["rotors"].size() ? YAML::Clone(doc["rotors"][i]) : YAML::Clone(doc["rotors"][0]);
      rot["position_B_m"] = vec3(v.rotors[i].position_B_m);
      rot["spin"] = v.rotors[i].spin;
      rot.SetStyle(YAML::EmitterStyle::Flow);
      rotors.push_back(rot);
    }
    doc["rotors"] = rotors;
  }
  for (size_t i = 0; i < doc["rotors"].size() && i < v.rotors.size(); ++i) {
    YAML::Node rot = doc["rotors"][i];
    if (rot["k_T_Nprps2"]) rot["k_T_Nprps2"] = v.rotors[i].k_T_Nprps2;
    if (rot["k_Q_Nmprps2"]) rot["k_Q_Nmprps2"] = v.rotors[i].k_Q_Nmprps2;
    if (rot["inertia_kgm2"]) rot["inertia_kgm2"] = v.rotors[i].inertia_kgm2;
  }
  doc["motor"]["inertia_kgm2"] = v.motor.inertia_kgm2;
  doc["drag"]["linear_Nspm"] = vec3(v.drag.linear_Nspm);
  doc["drag"]["quadratic_Ns2pm2"] = vec3(v.drag.quadratic_Ns2pm2);
  doc["battery"]["internal_resistance_ohm"] = v.battery.internal_resistance_ohm;
  doc["battery"]["cells_series"] = v.battery.cells_series;
  doc["battery"]["initial_soc"] = v.battery.initial_soc;
  // Control: the base's section (or the defaults), rescaled for a slower rotor.
  const double tau_base = HoverTau_s(base), tau_id = HoverTau_s(v);
  const double k = tau_base > 0 && tau_id > tau_base ? tau_base / tau_id : 1.0;
  std::string control_note = "the base's gains (the identified rotor is not slower than the base's)";
  if (k < 1.0) {
    control::ControllerParams cp;
    if (doc["control"]) {
      YamlReader reader(doc["control"], "base vehicle", "control");
      HEXSIM_RETURN_IF_ERROR(control::ParseControllerParams(reader, &cp));
    }
    doc["control"] = control::ControllerParamsToYaml(RescaledControl(cp, k));
    control_note = fmt::format("the base's gains slowed by k = tau_base/tau = {:.3g}/{:.3g} = {:.3f} (kp x k, ki x k^2)",
                               tau_base, tau_id, k);
  }
  YAML::Emitter e;
  e << doc;
  if (!e.good()) return Status::CheckFailed(std::string("identify: YAML emitter: ") + e.GetLastError());
  std::string head = fmt::format("# Identified by `hexsim identify` from {} (frame {}, {}); base vehicle {}.\n",
                                 r.windows.empty() ? "a log" : "the log", r.frame, r.frame_source, base.name);
  head += "# Fitted (95 % interval) or kept from the base:\n";
  for (const auto& k : r.param_order) {
    const Param& p = r.params.at(k);
    head += fmt::format("#   {:<32} {:>12.5g} [{:.5g}, {:.5g}] {} ({}{})\n", k, p.value, p.ci95[0], p.ci95[1], p.unit,
                        p.source, p.source == "fitted" ? (p.applied ? ", applied" : ", not applied: " + p.not_applied) : std::string());
  }
  head += "# Control: " + control_note + ".\n";  head += "# Rotors: " + (r.layout_from_log ? "the log's layout, from " + r.layout_source : "the base's") + ".\n";
  head += "# Applied: k_T (thrust_scale), k_Q (yaw_torque_coefficient_m), motor inertia (motor_time_constant_s),\n"
          "# drag, battery resistance/cells/initial SoC (IMU noise is reported only); only values whose interval lies inside the physical range are applied.\n"
          "# The controller's gains act on accelerations and its model of thrust and inertia comes from this\n"
          "# file, so the identified thrust enters through the model; a slower rotor slows the cascade.\n";
  return head + e.c_str() + "\n";
}

Status DropWiring(vehicle::VehicleParams* v, std::string* yaml_text) {
  YAML::Node doc;
  try {
    doc = YAML::Load(*yaml_text);
  } catch (const YAML::Exception& e) {
    return Status::BadInput(std::string("base vehicle: YAML: ") + e.what());
  }
  if (!doc.IsMap()) return Status::BadInput("base vehicle: YAML: not a mapping");
  doc.remove("wiring");
  v->wiring = magnetics::CurrentFieldParams{};
  YAML::Emitter e;
  e << doc;
  *yaml_text = "# wiring: removed (the base vehicle's wiring layout is not this airframe's; a log's current field\n"
               "# at its compasses is measured by gap diagnose and added to the updated vehicle)\n" +
               std::string(e.c_str()) + "\n";
  return Status::Ok();
}

Status WriteIdentifiedVehicle(const std::string& path, const BaseVehicle& base, const IdentifyResult& result,
                              std::string* outcome) {
  if (result.improves_on_base) {
    auto yaml = IdentifiedVehicleYaml(base.yaml, base.params, result);
    if (!yaml.ok()) return yaml.status();
    HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(path, *yaml));
    if (outcome) *outcome = "written";
    return Status::Ok();
  }
  std::error_code ec;
  const bool removed = std::filesystem::remove(path, ec);
  if (ec) return Status::BadInput(fmt::format("{}: cannot remove the vehicle file of an earlier run: {}", path, ec.message()));
  if (outcome) *outcome = removed ? "not written (the file an earlier run left there removed)" : "not written";
  return Status::Ok();
}

}  // namespace hexsim::identify
