#include "hexsim/magnetics/heading.h"

#include <cmath>

#include "hexsim/common/rotation.h"

namespace hexsim::magnetics {

Eigen::Vector2d TiltCompensated(const Eigen::Vector3d& m_B, double roll_rad, double pitch_rad) {
  const double sf = std::sin(roll_rad), cf = std::cos(roll_rad);
  const double st = std::sin(pitch_rad), ct = std::cos(pitch_rad);
  // X_h = m_x cosθ + m_y sinφ sinθ + m_z cosφ sinθ,  Y_h = m_y cosφ − m_z sinφ
  return {m_B.x() * ct + m_B.y() * sf * st + m_B.z() * cf * st, m_B.y() * cf - m_B.z() * sf};
}

double MagneticHeadingRad(const Eigen::Vector3d& m_B, double roll_rad, double pitch_rad) {
  const Eigen::Vector2d h = TiltCompensated(m_B, roll_rad, pitch_rad);
  return WrapPi(std::atan2(-h.y(), h.x()));  // ψ_mag = atan2(−Y_h, X_h)
}

double TrueHeadingRad(const Eigen::Vector3d& m_B, double roll_rad, double pitch_rad, double declination_rad) {
  return WrapPi(MagneticHeadingRad(m_B, roll_rad, pitch_rad) + declination_rad);
}

double FirstOrderHeadingErrorRad(const Eigen::Vector3d& dH_B, double heading_rad, double horizontal_uT,
                                 double /*inclination_rad*/) {
  // Δψ ≈ −(cos ψ·ΔY_h + sin ψ·ΔX_h) / (H cos σ), level: ΔX_h = ΔH_x, ΔY_h = ΔH_y.
  return -(std::cos(heading_rad) * dH_B.y() + std::sin(heading_rad) * dH_B.x()) / horizontal_uT;
}

}  // namespace hexsim::magnetics
