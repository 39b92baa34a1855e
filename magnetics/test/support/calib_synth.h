// Synthetic turntable for calibration tests: the paper's rig with a known hard-iron line
// β(u) = β0 + u·d, soft iron K, current I(u) = I_idle + k·u, and Gaussian sensor noise.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexsim/common/rng.h"
#include "hexsim/magnetics/compensator.h"

namespace hexsim::magnetics::testing {

struct SynthRig {
  // Earth field in NED (µT): about Changchun's (B_h ≈ 26.3 µT, inclination ≈ 60°).
  Eigen::Vector3d earth_N_uT = Eigen::Vector3d(26.0, -4.0, 45.0);
  Eigen::Matrix3d soft_iron = Eigen::Matrix3d::Identity();  // K (any scale)
  Eigen::Vector3d hard_iron0_uT = Eigen::Vector3d(12.0, -7.0, 20.0);
  Eigen::Vector3d d_uT_per_u = Eigen::Vector3d(0.010, -0.007, 0.012);  // hard-iron line direction·rate
  double current_idle_A = 0.6;
  double current_A_per_u = 0.175;  // 300 → ≈ 53 A, as the paper's table
  double noise_uT = 0.1;
  double angle_step_deg = 10.0;
  std::vector<std::string> planes = {"xy", "yz", "xz"};
  std::vector<double> controls_u = {0.0, 200.0, 300.0};

  Eigen::Vector3d HardIron(double u) const { return hard_iron0_uT + u * d_uT_per_u; }
  double Current(double u) const { return current_idle_A + current_A_per_u * u; }
};

// A symmetric, positive definite soft-iron matrix with det = 1 (few % scale, small cross terms).
Eigen::Matrix3d TestSoftIron();

// The table's attitude for `plane` at `angle_deg` (xy: yaw, yz: roll, xz: pitch).
Eigen::Quaterniond TableAttitude(const std::string& plane, double angle_deg);

// One full turn per plane per control amount. H = K·e_B + β(u) + noise; earth_B_uT = e_B.
std::vector<MagSample> Turntable(const SynthRig& rig, RngStream& rng);

}  // namespace hexsim::magnetics::testing
