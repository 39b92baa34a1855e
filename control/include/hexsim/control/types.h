// What the controller reads (NavState), what it is asked to do (Setpoint) and what it commands
// (ControlOutput). NED earth frame, FRD body frame; q_NB rotates body vectors into NED.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace hexsim::control {

// The vehicle state the controller uses: the simulator's truth now, the estimator's later.
struct NavState {
  double t_s = 0.0;
  Eigen::Vector3d p_N_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_N_mps = Eigen::Vector3d::Zero();
  Eigen::Vector3d w_B_radps = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_NB = Eigen::Quaterniond::Identity();
};

// One step's command from the mission sequencer (or a test) to the controller.
struct Setpoint {
  Eigen::Vector3d p_N_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_ff_N_mps = Eigen::Vector3d::Zero();   // velocity feed-forward
  Eigen::Vector3d a_ff_N_mps2 = Eigen::Vector3d::Zero();  // acceleration feed-forward
  double yaw_rad = 0.0;
  double yaw_rate_ff_radps = 0.0;
  // false: velocity control only (p_N_m ignored, v_ff_N_mps is the velocity setpoint).
  bool position_valid = true;
  // true: motors off (on the ground before take-off or after touchdown). The controller outputs
  // zero and resets its integrators.
  bool idle = false;
  // true: on the ground before lift-off (ArduPilot's take-off while land_complete): the position
  // and velocity loops stay reset, the attitude loops level the vehicle at yaw_rad, and the
  // collective is ground_thrust_fraction of the vehicle's largest thrust, ramped by the sequencer.
  bool ground_ramp = false;
  double ground_thrust_fraction = 0.0;
  // true: landing, probably on the ground (ArduPilot's land_complete_maybe): the rate and the
  // horizontal velocity integrators are held at zero (they would wind up against the ground's
  // reaction and tip the vehicle), and the sequencer holds the yaw and the position the vehicle has.
  bool ground_contact = false;
};

// Collective thrust along -z_B and body torque; the mixer turns them into rotor thrusts.
struct ControlOutput {
  double thrust_N = 0.0;
  Eigen::Vector3d torque_B_Nm = Eigen::Vector3d::Zero();
};

}  // namespace hexsim::control
