#include "hexsim/magnetics/compass_model.h"

#include <Eigen/LU>

namespace hexsim::magnetics {
namespace {

// scale·K(I), K(I) = K + I·dK/dI.
Eigen::Matrix3d Gain(const CompassErrorParams& p, double battery_current_A) {
  return p.scale * (p.soft_iron + battery_current_A * p.soft_iron_per_A);
}

constexpr double kMinReciprocalCondition = 1e-12;

}  // namespace

Eigen::Vector3d ApplyCompassError(const CompassErrorParams& p, const Eigen::Vector3d& true_field_B_uT,
                                  double battery_current_A) {
  // H = R_SB·(scale·K(I)·H̃_B) + β
  return p.R_SB * (Gain(p, battery_current_A) * true_field_B_uT) + p.hard_iron_uT;
}

bool InvertCompassError(const CompassErrorParams& p, const Eigen::Vector3d& reading_uT,
                        double battery_current_A, Eigen::Vector3d* true_field_B_uT) {
  const Eigen::Matrix3d gain = Gain(p, battery_current_A);
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(gain);
  if (!lu.isInvertible() || lu.rcond() < kMinReciprocalCondition || !gain.allFinite()) return false;
  // H̃_B = (scale·K(I))⁻¹·R_SBᵀ·(H − β)
  *true_field_B_uT = lu.solve(p.R_SB.transpose() * (reading_uT - p.hard_iron_uT));
  return true;
}

Eigen::Vector3d NoiselessCompassReading_uT(const CompassErrorParams& error, const CurrentFieldParams& wiring,
                                           const Eigen::Vector3d& sensor_p_B_m, const Eigen::Matrix3d& R_NB,
                                           const Eigen::Vector3d& B_N_uT, const Currents& currents) {
  // H̃_B = R_NBᵀ·B_N + B_current(p)
  const Eigen::Vector3d true_field_B_uT =
      R_NB.transpose() * B_N_uT + CurrentDrivenField_uT(wiring, sensor_p_B_m, currents);
  return ApplyCompassError(error, true_field_B_uT, currents.battery_A);
}

}  // namespace hexsim::magnetics
