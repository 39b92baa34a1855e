// The vehicle configuration with the fitted effects added.
#include <algorithm>
#include <cmath>
#include <sstream>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "hexsim/common/rotation.h"
#include "hexsim/gap/diagnose.h"

namespace hexsim::gap {
namespace {

YAML::Node Vec(const Eigen::Vector3d& v) {
  YAML::Node n(YAML::NodeType::Sequence);
  for (int i = 0; i < 3; ++i) n.push_back(v[i]);
  n.SetStyle(YAML::EmitterStyle::Flow);
  return n;
}

YAML::Node Mat(const Eigen::Matrix3d& m) {
  YAML::Node n(YAML::NodeType::Sequence);
  for (int r = 0; r < 3; ++r) n.push_back(Vec(m.row(r).transpose()));
  n.SetStyle(YAML::EmitterStyle::Flow);
  return n;
}

double Value(const Params& p, const char* name) {
  const auto it = p.find(name);
  return it != p.end() ? it->second : 0.0;
}

Eigen::Vector3d ParamVec(const Params& p, const char* a, const char* b, const char* c) {
  return {Value(p, a), Value(p, b), Value(p, c)};
}

int CompassIndex(const std::string& channel) {
  if (channel == "mag") return 0;
  if (channel.rfind("mag", 0) == 0) return std::atoi(channel.c_str() + 3) - 1;
  return -1;
}

// The dynamics channel's fitted effects as vehicle keys (aero:, battery:, motor:, rotor_defaults:).
void AddDynamicsEffects(const ChannelResult& ch, const vehicle::VehicleParams& v, YAML::Node* root,
                        std::vector<std::string>* notes) {
  if (ch.verdict == "none") return;
  for (const CandidateResult& k : ch.candidates) {
    if (!k.selected) continue;
    const Params& p = k.params;
    if (k.id == Effect::kRotorDrag) {
      (*root)["aero"]["rotor_drag_N_per_radps_mps"] =
          v.aero.rotor_drag_N_per_radps_mps + Value(p, "rotor_drag_N_per_radps_mps");
    } else if (k.id == Effect::kGroundEffect) {
      (*root)["aero"]["ground_effect_radius_m"] = Value(p, "radius_m");
    } else if (k.id == Effect::kBatterySag) {
      const double dR = Value(p, "delta_R_ohm");
      (*root)["battery"]["internal_resistance_ohm"] = std::max(0.0, v.battery.internal_resistance_ohm + dR);
      notes->push_back(fmt::format("dynamics: battery_sag {:.4f} ohm added to battery.internal_resistance_ohm (the ESCs "
                                   "see that much less voltage per ampere than the thrust model assumed)",
                                   dR));
    } else if (k.id == Effect::kMotorTimeConstant && !v.rotors.empty()) {
      // τ ∝ J at a given rotor speed: scale the motor inertia so hover gains the fitted extra τ.
      const double tau = HoverRotorTimeConstant_s(v);
      if (!(tau > 0)) continue;
      const double factor = std::max(0.1, 1.0 + Value(p, "tau_extra_s") / tau);
      (*root)["motor"]["inertia_kgm2"] = v.motor.inertia_kgm2 * factor;
      notes->push_back(fmt::format("dynamics: motor_time_constant +{:.3f} s at hover: motor.inertia_kgm2 x {:.3f} (rotors "
                                   "with their own inertia_kgm2 are not changed)",
                                   Value(p, "tau_extra_s"), factor));
    } else if (k.id == Effect::kThrustScale) {
      const double s = 1.0 + Value(p, "thrust_scale_minus_1");
      if ((*root)["rotor_defaults"] && (*root)["rotor_defaults"]["k_T_Nprps2"]) {
        (*root)["rotor_defaults"]["k_T_Nprps2"] = (*root)["rotor_defaults"]["k_T_Nprps2"].as<double>() * s;
      } else {
        notes->push_back(fmt::format("dynamics: thrust_scale {:.4f}: multiply every rotor's k_T_Nprps2 by it", s));
      }
    } else {
      notes->push_back(fmt::format("dynamics: {} fitted ({}) but the vehicle schema has no key for it{}", k.effect,
                                   ParamsText(p), k.id == Effect::kWind ? " (it is the world's wind.mean_N_mps)" : ""));
    }
  }
}

}  // namespace

Result<std::string> UpdatedVehicleYaml(const std::string& text, const vehicle::VehicleParams& v, const GapReport& report) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    return Status::BadInput(std::string("vehicle: ") + e.what());
  }
  std::vector<std::string> notes;
  for (const ChannelResult& ch : report.channels) {
    if (ch.channel == "dynamics") {
      AddDynamicsEffects(ch, v, &root, &notes);
      continue;
    }
    // The vehicle file's compass the channel was compared with (compass_map.h), else by its prefix.
    const int c = ch.vehicle_compass > 0 ? ch.vehicle_compass - 1 : CompassIndex(ch.channel);
    if (c < 0 || c >= static_cast<int>(v.compasses.size()) || !root["compasses"] || !root["compasses"][c]) continue;
    YAML::Node node = root["compasses"][c];
    const vehicle::CompassParams& cp = v.compasses[c];
    const Eigen::Matrix3d M = cp.error.R_SB * cp.error.scale * cp.error.soft_iron;
    for (const CandidateResult& k : ch.candidates) {
      if (!k.selected || ch.verdict == "none") continue;
      const Params& p = k.params;
      if (k.id == Effect::kHardIronOffset) {
        node["hard_iron_uT"] = Vec(cp.error.hard_iron_uT + ParamVec(p, "b_x_uT", "b_y_uT", "b_z_uT"));
      } else if (k.id == Effect::kScaleError || k.id == Effect::kFieldScale) {
        node["scale"] = cp.error.scale * (1.0 + Value(p, "scale_minus_1"));
      } else if (k.id == Effect::kMisalignment) {
        const Eigen::Vector3d phi = ParamVec(p, "phi_x_deg", "phi_y_deg", "phi_z_deg") * kDegToRad;
        // R_SB_new = exp([φ]×)·R_SB; orientation_rpy_deg holds the body-to-sensor rotation.
        const Eigen::Matrix3d R = QuatExp(phi).toRotationMatrix() * cp.error.R_SB;
        const Eigen::Vector3d rpy = EulerFromQuat(Eigen::Quaterniond(R.transpose())) * kRadToDeg;
        node["orientation_rpy_deg"] = Vec(rpy);
      } else if (k.id == Effect::kCurrentSoftIron) {
        Eigen::Matrix3d E;
        const char* n[9] = {"dK_xx_per_A", "dK_xy_per_A", "dK_xz_per_A", "dK_yx_per_A", "dK_yy_per_A",
                            "dK_yz_per_A", "dK_zx_per_A", "dK_zy_per_A", "dK_zz_per_A"};
        for (int i = 0; i < 9; ++i) E(i / 3, i % 3) = Value(p, n[i]);
        // E·M = R_SB·scale·dK  →  dK = (R_SB·scale)⁻¹·E·M
        const Eigen::Matrix3d dK = (cp.error.R_SB * cp.error.scale).inverse() * E * M;
        node["soft_iron_per_A"] = Mat(cp.error.soft_iron_per_A + dK);
      } else if (k.id == Effect::kCurrentLag && p.count("exponent") == 0) {  // the configured wiring's lag
        node["current_lag_tau_s"] = Value(p, "tau_s");
      } else if (k.id == Effect::kCurrentHardIron) {
        // A short battery-current segment next to the compass whose field there is d_B per ampere:
        // wire along u ⊥ d̂, compass at ρ·(d̂ × u) from its middle; B = μ0 I/(4πρ)·2L/√(L² + ρ²).
        const Eigen::Vector3d d_s = ParamVec(p, "d_x_uT_per_A", "d_y_uT_per_A", "d_z_uT_per_A");
        const Eigen::Vector3d d_B = M.inverse() * d_s;
        const double mag = d_B.norm();
        if (!(mag > 0)) continue;
        const Eigen::Vector3d dh = d_B / mag;
        Eigen::Vector3d u = dh.unitOrthogonal();
        constexpr double kRho_m = 0.003, kHalf_m = 0.002;
        const Eigen::Vector3d s = dh.cross(u) * kRho_m;  // from the wire's middle to the compass
        const Eigen::Vector3d mid = cp.position_B_m - s;
        const double per_A = magnetics::kMu0Over4Pi_uTmpA / kRho_m * 2 * kHalf_m / std::hypot(kHalf_m, kRho_m);
        YAML::Node seg;
        seg["name"] = fmt::format("gap_fitted_{}_current_hard_iron", ch.channel);
        seg["a_B_m"] = Vec(mid - u * kHalf_m);
        seg["b_B_m"] = Vec(mid + u * kHalf_m);
        seg["source"] = "battery";
        seg["share"] = mag / per_A;
        root["wiring"]["segments"].push_back(seg);
        notes.push_back(fmt::format("{}: current_hard_iron {:.3f} uT/A added as the wiring segment '{}' 3 mm from the "
                                    "compass (a compass within ~1 cm also sees a little of it)",
                                    ch.channel, mag, seg["name"].as<std::string>()));
      } else {
        notes.push_back(fmt::format("{}: {} fitted ({}) but the vehicle schema has no key for it", ch.channel, k.effect,
                                    ParamsText(p)));
      }
    }
  }
  YAML::Emitter em;
  em << root;
  std::string out = "# Updated by `hexsim gap diagnose` from " + report.log_name + ".\n";
  for (const auto& n : notes) out += "# " + n + "\n";
  out += em.c_str();
  out += "\n";
  return out;
}

}  // namespace hexsim::gap
