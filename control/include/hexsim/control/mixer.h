// Control allocation for an N-rotor vehicle: [thrust; τx; τy; τz] = A·t, t = rotor thrusts (N).
//
// Rotor i at p_B_m pushing along the unit thrust axis a_B (usually (0,0,−1): up) with thrust t_i:
//   force  F = t_i·a_B            → collective thrust row: −a_B.z (thrust is counted along −z_B)
//   torque τ = p_B_m × (t_i·a_B) − spin_i·(k_Q/k_T)·t_i·a_B   (rotor drag reacts against its spin)
// spin = +1: the rotor turns counter-clockwise seen from above (its angular velocity points along
// the thrust axis), so its drag yaws the body clockwise from above (positive τz, FRD); −1: clockwise.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "hexsim/common/status.h"

namespace hexsim::control {

struct RotorGeometry {
  Eigen::Vector3d p_B_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d thrust_axis_B = -Eigen::Vector3d::UnitZ();
  int spin = 1;                     // +1 counter-clockwise seen from above, −1 clockwise
  double torque_to_thrust_m = 0.016;  // k_Q/k_T: drag torque per unit thrust
};

struct MixResult {
  Eigen::VectorXd thrust_N;        // per rotor, in [0, max]
  bool saturated = false;          // the requested wrench could not be produced exactly
  double roll_pitch_scale = 1.0;   // fraction of the requested roll/pitch torque kept
  double yaw_scale = 1.0;          // fraction of the requested yaw torque kept
  Eigen::Vector4d achieved = Eigen::Vector4d::Zero();  // A·thrust_N: [thrust_N, τx, τy, τz]
};

class Mixer {
 public:
  // Bad input: fewer than 4 rotors, a zero thrust axis, |spin| != 1, or a geometry that cannot
  // produce all of thrust, roll, pitch and yaw (rank(A) < 4).
  static Result<Mixer> Create(const std::vector<RotorGeometry>& rotors);

  // Rotor thrusts for the requested collective thrust and body torque, each in [0, max]. When the
  // request does not fit: roll/pitch torque is kept first (the collective is shifted to make room,
  // and roll/pitch scaled down only when no collective fits), then the collective, and yaw last
  // (scaled down until it fits).
  MixResult Mix(double thrust_N, const Eigen::Vector3d& torque_B_Nm, double max_rotor_thrust_N) const;
  // The same into a caller-owned result (every field overwritten; its thrust_N storage is reused,
  // so a caller that keeps one MixResult allocates nothing per call).
  void Mix(double thrust_N, const Eigen::Vector3d& torque_B_Nm, double max_rotor_thrust_N, MixResult* out) const;

  const Eigen::MatrixXd& allocation() const { return A_; }         // 4×N
  const Eigen::MatrixXd& pseudo_inverse() const { return A_pinv_; }  // N×4
  int rotor_count() const { return static_cast<int>(A_.cols()); }

 private:
  Mixer(Eigen::MatrixXd A, Eigen::MatrixXd A_pinv) : A_(std::move(A)), A_pinv_(std::move(A_pinv)) {}
  Eigen::MatrixXd A_;
  Eigen::MatrixXd A_pinv_;
};

// Builds the allocation matrix (no checks).
Eigen::MatrixXd AllocationMatrix(const std::vector<RotorGeometry>& rotors);

// The paper's collective "control amount": mean rotor command (each 0…1) × 1000, in 0…1000.
double ControlAmount(const Eigen::VectorXd& rotor_commands);

// A flat rotor layout for tests and quick setups: n rotors evenly spaced on a circle of radius
// arm_m, the first at first_angle_deg from the nose (clockwise from above), spins alternating
// starting with first_spin. Hex "X": n=6, 30°; quad X: n=4, 45° (spins as the caller needs).
std::vector<RotorGeometry> CircularLayout(int n, double arm_m, double first_angle_deg, int first_spin,
                                          double torque_to_thrust_m = 0.016);

}  // namespace hexsim::control
