#include "hexsim/vehicle/rotor_wrench.h"

#include <Eigen/Geometry>

namespace hexsim::vehicle {

RotorWrenchTable::RotorWrenchTable(const VehicleParams& params) {
  rotors_.reserve(params.rotors.size());
  for (size_t i = 0; i < params.rotors.size(); ++i) {
    const RotorParams& r = params.rotors[i];
    const Eigen::Vector3d k_T_a = r.k_T_Nprps2 * r.axis_B;
    rotors_.push_back({k_T_a, r.position_B_m.cross(k_T_a) - r.spin * r.k_Q_Nmprps2 * r.axis_B,
                       r.spin * params.RotorInertia_kgm2(i) * r.axis_B});
  }
}

Wrench RotorWrenchTable::operator()(const std::vector<double>& omega_radps, const Eigen::Vector3d& w_B_radps) const {
  HEXSIM_CHECK(omega_radps.size() == rotors_.size());
  Wrench w;
  Eigen::Vector3d h_B = Eigen::Vector3d::Zero();  // rotors' spin angular momentum, N*m*s
  for (size_t i = 0; i < rotors_.size(); ++i) {
    const double om = omega_radps[i];
    const double om2 = om * om;
    w.force_B_N += om2 * rotors_[i].force_per_w2;
    w.torque_B_Nm += om2 * rotors_[i].torque_per_w2;
    h_B += om * rotors_[i].h_per_w;
  }
  w.torque_B_Nm -= w_B_radps.cross(h_B);  // gyroscopic: body must turn the rotors' momentum
  return w;
}

}  // namespace hexsim::vehicle
