#include "hexsim/vehicle/rotor_wrench.h"

#include <Eigen/Geometry>

namespace hexsim::vehicle {

RotorWrenchTable::RotorWrenchTable(const VehicleParams& params) : rotor_count_(params.rotors.size()) {
  coef_.reserve(kStride * rotor_count_);
  for (size_t i = 0; i < rotor_count_; ++i) {
    const RotorParams& r = params.rotors[i];
    const Eigen::Vector3d k_T_a = r.k_T_Nprps2 * r.axis_B;
    const Eigen::Vector3d torque = r.position_B_m.cross(k_T_a) - r.spin * r.k_Q_Nmprps2 * r.axis_B;
    const Eigen::Vector3d h = r.spin * params.RotorInertia_kgm2(i) * r.axis_B;
    for (const Eigen::Vector3d* v : {&k_T_a, &torque, &h}) coef_.insert(coef_.end(), v->data(), v->data() + 3);
  }
}

Wrench RotorWrenchTable::operator()(const std::vector<double>& omega_radps, const Eigen::Vector3d& w_B_radps) const {
  HEXSIM_CHECK(omega_radps.size() == rotor_count_);
  double ft[6] = {0, 0, 0, 0, 0, 0};  // force, torque
  double h[3] = {0, 0, 0};            // rotors' spin angular momentum, N*m*s
  const double* c = coef_.data();
  for (size_t i = 0; i < rotor_count_; ++i, c += kStride) {
    const double om = omega_radps[i];
    const double om2 = om * om;
    for (int k = 0; k < 6; ++k) ft[k] += om2 * c[k];
    for (int k = 0; k < 3; ++k) h[k] += om * c[6 + k];
  }
  Wrench w;
  w.force_B_N = Eigen::Vector3d(ft[0], ft[1], ft[2]);
  w.torque_B_Nm = Eigen::Vector3d(ft[3], ft[4], ft[5]);
  w.torque_B_Nm -= w_B_radps.cross(Eigen::Vector3d(h[0], h[1], h[2]));  // gyroscopic: body must turn the rotors' momentum
  return w;
}

}  // namespace hexsim::vehicle
