// Where a caller (an agent, a Python controller) acts on a sim::Simulation, through the run loop's
// Plugins:
//   builtin   the mission flown by the built-in cascade
//   position  the built-in cascade flies to p_sp_N_m with yaw yaw_sp_rad (setpoint hook)
//   attitude  q_sp_NB and thrust_N: the cascade's attitude and rate loops (plug-in controller)
//   rates     w_sp_B_radps and thrust_N: the cascade's rate loop (plug-in controller)
//   motors    one command per motor in [0, 1], after the mixer and the slew (command hook)
// The action is held: it acts on every autopilot tick until changed.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "hexsim/control/controller.h"
#include "hexsim/sim/simulation.h"

namespace hexsim::envs {

enum class ActMode { kBuiltin, kPosition, kAttitude, kRates, kMotors };

const char* ActModeName(ActMode mode);

// What the caller asked for last; read by the plug-ins on every autopilot tick. The plug-ins hold
// its address: keep it where it does not move (e.g. on the heap) for the simulation's lifetime.
struct Action {
  ActMode mode = ActMode::kBuiltin;
  Eigen::Vector3d p_sp_N_m = Eigen::Vector3d::Zero();
  double yaw_sp_rad = 0.0;
  Eigen::Quaterniond q_sp_NB = Eigen::Quaterniond::Identity();
  Eigen::Vector3d w_sp_B_radps = Eigen::Vector3d::Zero();
  double thrust_N = 0.0;
  std::vector<double> motors;
};

// The built-in CascadedController entered at the loop `action->mode` names (the whole cascade
// otherwise), the setpoint hook (position mode; any mode but builtin and motors keeps the motors
// running whatever the mission's state) and the command hook (motors mode).
sim::Plugins ActPlugins(const sim::RunSetup& setup, const Action* action);

}  // namespace hexsim::envs
