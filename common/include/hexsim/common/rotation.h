// Frames and rotations. Earth frame N = North-East-Down, body frame B = Forward-Right-Down.
// q_NB (Hamilton, scalar first) rotates body vectors into NED: v_N = q_NB * v_B.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace hexsim {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kDegToRad = kPi / 180.0;
inline constexpr double kRadToDeg = 180.0 / kPi;
inline constexpr double kGravity_mps2 = 9.80665;

// Wraps to (-pi, pi].
double WrapPi(double angle_rad);
// Wraps to (-180, 180].
double WrapDeg180(double angle_deg);

// ZYX Euler angles (roll φ about x, pitch θ about y, yaw ψ about z): R_NB = Rz(ψ)·Ry(θ)·Rx(φ).
Eigen::Quaterniond QuatFromEuler(double roll_rad, double pitch_rad, double yaw_rad);
// (roll, pitch, yaw) in radians; yaw in (-pi, pi].
Eigen::Vector3d EulerFromQuat(const Eigen::Quaterniond& q_NB);
// Yaw of q_NB in degrees, (-180, 180] from true north.
double YawDeg(const Eigen::Quaterniond& q_NB);

// Skew-symmetric matrix [v]x with [v]x·w = v × w.
Eigen::Matrix3d Skew(const Eigen::Vector3d& v);
// Quaternion exponential of a rotation vector (axis·angle).
Eigen::Quaterniond QuatExp(const Eigen::Vector3d& rotation_vector);
// Rotation vector of a quaternion (inverse of QuatExp), shortest path.
Eigen::Vector3d QuatLog(const Eigen::Quaterniond& q);

}  // namespace hexsim
