// Tilt-compensated compass heading, NED/FRD (CONTRACTS.md):
//   X_h = m_x cosθ + m_y sinφ sinθ + m_z cosφ sinθ,  Y_h = m_y cosφ − m_z sinφ,
//   ψ_mag = atan2(−Y_h, X_h),  ψ_true = ψ_mag + declination.
// (The paper's eq. 2 drops the sign and its eq. 7 swaps φ and θ; these are the corrected forms.)
#pragma once

#include <Eigen/Core>

namespace hexsim::magnetics {

// Magnetic heading (rad, (−π, π]) of the body-frame field m_B at roll φ, pitch θ.
double MagneticHeadingRad(const Eigen::Vector3d& m_B, double roll_rad, double pitch_rad);

// True heading ψ_mag + declination, wrapped to (−π, π].
double TrueHeadingRad(const Eigen::Vector3d& m_B, double roll_rad, double pitch_rad, double declination_rad);

// Horizontal components (X_h, Y_h) of the body-frame field after tilt compensation.
Eigen::Vector2d TiltCompensated(const Eigen::Vector3d& m_B, double roll_rad, double pitch_rad);

// Paper eq. 9, first-order heading error of a level vehicle from a body-frame field change:
//   Δψ ≈ −(cos ψ·ΔY_h + sin ψ·ΔX_h) / (H cos σ),  with ΔX_h = ΔH_x, ΔY_h = ΔH_y when level.
// horizontal_uT is the paper's H cos σ (σ = inclination). inclination_rad does not enter the result:
// given H cos σ it is redundant, and at level attitude ΔZ does not enter; it is kept so that callers
// state the paper's (H, σ) pair.
// For comparison only: compute heading errors exactly with TrueHeadingRad.
double FirstOrderHeadingErrorRad(const Eigen::Vector3d& dH_B, double heading_rad, double horizontal_uT,
                                 double inclination_rad);

}  // namespace hexsim::magnetics
