// The fixed-step closed loop: ODE rigid body + powertrain + sensors + autopilot (estimator,
// compass compensation, mission sequencer, controller, mixer) + FlightLog at the log rate.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "hexsim/common/status.h"
#include "hexsim/control/controller.h"
#include "hexsim/control/mission.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/magnetics/compensator.h"
#include "hexsim/nav/estimator.h"
#include "hexsim/sim/world.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::sim {

struct SimOptions {
  double physics_dt_s = 0.001;   // 1 kHz physics
  double log_rate_hz = 100.0;
  double duration_s = 0.0;       // 0: until the mission is over (or max_duration_s)
  double max_duration_s = 900.0;
  double settle_after_landing_s = 1.0;  // keep logging this long after touchdown
  uint64_t seed = 1;
  // "truth" (the controller reads the true state), "eskf" or "complementary".
  std::string estimator = "eskf";
  // true: the estimator runs and is logged, but the controller flies on the true state (to study
  // an estimator open-loop).
  bool control_on_truth = false;
  // Autopilot motor-command slew limit upwards (1/s), as ArduPilot's spool-up: without it an ESC
  // jumping from stop to hover duty draws hundreds of amperes for a few milliseconds.
  double motor_slew_up_per_s = 4.0;
  bool write_log = true;
};

// Everything one run needs; plain data, validated before a run starts.
struct RunSetup {
  vehicle::VehicleParams vehicle;
  WorldParams world;
  control::Mission mission;  // resolved (NED waypoints)
  control::ControllerParams control;
  nav::NavParams nav;
  // Compass compensation applied to compass 1 before the estimator; nullptr = raw reading.
  std::shared_ptr<const magnetics::Compensator> compensator;
  SimOptions options;
  // Names for the summary and the meta file.
  std::string mission_name, vehicle_name, world_name, calibration_name = "none";
};

struct RunOutput {
  logs::FlightLog log;
  nlohmann::json summary;  // hexsim.summary/1
  // OK, or kNumerical when the run diverged (the log and summary are still complete up to then).
  Status status;
};

// Validates cross-file consistency (e.g. the date against the field model) before anything runs.
Status ValidateRunSetup(const RunSetup& setup);

// Flies the mission. Deterministic: same setup → same log, byte for byte.
RunOutput RunMission(const RunSetup& setup);

}  // namespace hexsim::sim
