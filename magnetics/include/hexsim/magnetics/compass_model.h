// Compass sensor error model, the paper's eq. 3: H = K·H̃ + β, extended with a battery-current
// dependent soft iron, a sensor-to-body misalignment and a scale error.
#pragma once

#include <Eigen/Core>

#include "hexsim/magnetics/current_field.h"

namespace hexsim::magnetics {

struct CompassErrorParams {
  Eigen::Matrix3d soft_iron = Eigen::Matrix3d::Identity();    // K
  Eigen::Vector3d hard_iron_uT = Eigen::Vector3d::Zero();     // β, in the sensor frame
  Eigen::Matrix3d soft_iron_per_A = Eigen::Matrix3d::Zero();  // optional: K(I) = K + I_batt·dK/dI, 1/A
  Eigen::Matrix3d R_SB = Eigen::Matrix3d::Identity();         // misalignment: rotates body vectors into sensor axes
  double scale = 1.0;                                          // optional scale error
};

// Reading in the (nominally body) sensor frame:
//   H = R_SB·(scale·K(I)·H̃_B) + β,   K(I) = K + I_batt·dK/dI,
// where H̃_B is the true field at the sensor in the body frame (Earth field in body + current-driven
// field). Allocation-free.
Eigen::Vector3d ApplyCompassError(const CompassErrorParams& p, const Eigen::Vector3d& true_field_B_uT,
                                  double battery_current_A);

// The inverse for a known current: H̃_B = (scale·K(I))⁻¹·R_SBᵀ·(H − β). Returns false (and leaves
// *true_field_B_uT untouched) when scale·K(I) is singular or ill-conditioned (reciprocal condition
// number below 1e-12).
bool InvertCompassError(const CompassErrorParams& p, const Eigen::Vector3d& reading_uT,
                        double battery_current_A, Eigen::Vector3d* true_field_B_uT);

// The noiseless reading of a compass at sensor_p_B_m on a vehicle with attitude R_NB in the Earth
// field B_N_uT: H = R_SB·scale·K(I_batt)·(R_NBᵀ·B_N + B_current(p)) + β. Pass the (lagged, see
// StepCurrentLag) currents; K(I) uses currents.battery_A. Allocation-free.
Eigen::Vector3d NoiselessCompassReading_uT(const CompassErrorParams& error, const CurrentFieldParams& wiring,
                                           const Eigen::Vector3d& sensor_p_B_m, const Eigen::Matrix3d& R_NB,
                                           const Eigen::Vector3d& B_N_uT, const Currents& currents);

}  // namespace hexsim::magnetics
