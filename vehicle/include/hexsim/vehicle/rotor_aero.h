// Rotor aerodynamics beyond k_T·ω² (vehicle `aero:`, AeroParams), as a pure function of the rotor
// speeds and the body's air velocity, height and attitude:
//   rotor drag (induced drag / blade flapping): F_B = −k·(Σ_i ω_i)·(v_x, v_y, 0), v the body air
//   velocity, in the rotor plane;
//   ground effect (Cheeseman–Bennett): per rotor T_IGE/T_OGE = 1/(1 − (R/4z)²), z the hub height
//   above the ground plane D = 0 (clamped to ≥ R/2), the extra thrust along the rotor axis with its
//   moment r × ΔF about the centre of mass.
#pragma once

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "hexsim/vehicle/powertrain.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::vehicle {

// true when either term is on (both 0 = off, the default).
inline bool RotorAeroEnabled(const AeroParams& a) {
  return a.rotor_drag_N_per_radps_mps > 0.0 || a.ground_effect_radius_m > 0.0;
}

// The wrench of both terms on the body (body frame, about the centre of mass); zero when off.
// `cg_D_m` is the centre of mass's NED down coordinate, `q_NB` the attitude (for hub heights).
Wrench RotorAeroWrench(const VehicleParams& params, const std::vector<double>& omega_radps,
                       const Eigen::Vector3d& v_air_B_mps, double cg_D_m, const Eigen::Quaterniond& q_NB);

}  // namespace hexsim::vehicle
