#include "hexsim/vehicle/rotor_aero.h"

#include <algorithm>

namespace hexsim::vehicle {

Wrench RotorAeroWrench(const VehicleParams& params, const std::vector<double>& omega_radps,
                       const Eigen::Vector3d& v_air_B_mps, double cg_D_m, const Eigen::Quaterniond& q_NB) {
  HEXSIM_CHECK(omega_radps.size() == params.rotors.size());
  const AeroParams& aero = params.aero;
  Wrench w;
  if (aero.rotor_drag_N_per_radps_mps > 0.0) {
    double omega_sum = 0.0;
    for (double om : omega_radps) omega_sum += om;
    w.force_B_N += -aero.rotor_drag_N_per_radps_mps * omega_sum * Eigen::Vector3d(v_air_B_mps.x(), v_air_B_mps.y(), 0.0);
  }
  if (aero.ground_effect_radius_m > 0.0) {
    const double R = aero.ground_effect_radius_m;
    for (size_t i = 0; i < params.rotors.size(); ++i) {
      const RotorParams& rp = params.rotors[i];
      const double hub_D_m = cg_D_m + (q_NB * rp.position_B_m).z();
      const double z_m = std::max(0.5 * R, -hub_D_m);
      const double x = R / (4.0 * z_m);
      const double extra = 1.0 / (1.0 - x * x) - 1.0;
      const Eigen::Vector3d dF_B = extra * rp.k_T_Nprps2 * omega_radps[i] * omega_radps[i] * rp.axis_B;
      w.force_B_N += dF_B;
      w.torque_B_Nm += rp.position_B_m.cross(dF_B);
    }
  }
  return w;
}

}  // namespace hexsim::vehicle
