// The rotors' wrench on the body (RotorWrench in powertrain.h) with its per-rotor constants folded
// once per vehicle, for the 1 kHz physics loop:
//   F   = Σ ω_i² · (k_T,i a_i)
//   τ   = Σ ω_i² · (k_T,i p_i × a_i − s_i k_Q,i a_i) − w_B × h,   h = Σ ω_i · (s_i J_r,i a_i)
// (a_i thrust axis, p_i position, s_i spin ±1, J_r,i rotor inertia). The same law as RotorWrench
// without the spin-up reaction; the products are grouped differently, so the result differs from
// RotorWrench's by rounding only (relative 1e-16).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "hexsim/vehicle/powertrain.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::vehicle {

class RotorWrenchTable {
 public:
  explicit RotorWrenchTable(const VehicleParams& params);
  // Force and torque on the body, body frame, at rotor speeds omega_radps (one per rotor) and body
  // rate w_B_radps (gyroscopic term).
  Wrench operator()(const std::vector<double>& omega_radps, const Eigen::Vector3d& w_B_radps) const;

 private:
  // Per rotor, contiguous: k_T a (N/(rad/s)²), k_T p × a − s k_Q a (N·m/(rad/s)²), then s J_r a
  // (N·m·s/(rad/s)). One flat array so the sums vectorise; each component is still the same
  // sequence of products and additions, so the result is the same bits as three Vector3d sums.
  static constexpr int kStride = 9;
  std::vector<double> coef_;
  size_t rotor_count_ = 0;
};

}  // namespace hexsim::vehicle
