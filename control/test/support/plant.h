// A tiny rigid-body multirotor plant for closing the loop in control tests (no ODE): 6-DOF rigid
// body, first-order rotor lag, linear drag, a flat ground at D = 0 with the CoM resting on it.
#pragma once

#include <Eigen/Core>

#include "hexsim/control/mixer.h"
#include "hexsim/control/types.h"

namespace hexsim::control::testing {

struct PlantParams {
  double mass_kg = 5.0;
  Eigen::Matrix3d inertia_kgm2 = Eigen::Vector3d(0.12, 0.12, 0.22).asDiagonal();
  double rotor_tau_s = 0.03;     // first-order lag of each rotor's thrust
  double drag_Nspmps = 0.25;     // linear translational drag, N per m/s
  double max_rotor_thrust_N = 0.0;  // 0: 2× the hover share of each rotor
  bool ground = true;
};

class RigidBodyPlant {
 public:
  RigidBodyPlant(const PlantParams& params, Mixer mixer);

  // One step: mix the command (with saturation), lag the rotor thrusts, integrate.
  void Step(const ControlOutput& command, double dt_s);
  // Bypasses the mixer and the rotor lag: applies this wrench exactly.
  void StepWrench(double thrust_N, const Eigen::Vector3d& torque_B_Nm, double dt_s);

  // Rotor thrusts at the hover share (starting airborne in trim).
  void TrimForHover() { rotor_thrust_N_.setConstant(mass_kg_ * 9.80665 / mixer_.rotor_count()); }
  NavState& state() { return state_; }
  const NavState& state() const { return state_; }
  double mass_kg() const { return mass_kg_; }
  void set_mass_kg(double m) { mass_kg_ = m; }
  double max_rotor_thrust_N() const { return max_rotor_thrust_N_; }
  const Mixer& mixer() const { return mixer_; }
  const MixResult& last_mix() const { return last_mix_; }
  bool on_ground() const { return on_ground_; }

 private:
  PlantParams params_;
  Mixer mixer_;
  NavState state_;
  double mass_kg_ = 0.0;
  double max_rotor_thrust_N_ = 0.0;
  Eigen::VectorXd rotor_thrust_N_;
  MixResult last_mix_;
  bool on_ground_ = false;
};

// A 6-rotor X layout (0.6 m arms) and a 4-rotor X layout (0.25 m arms), alternating spins.
std::vector<RotorGeometry> HexLayout();
std::vector<RotorGeometry> QuadLayout();

}  // namespace hexsim::control::testing
