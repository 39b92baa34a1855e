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
#include "hexsim/sim/rigid_body.h"
#include "hexsim/sim/run_summary.h"
#include "hexsim/sim/world.h"
#include "hexsim/vehicle/powertrain.h"
#include "hexsim/vehicle/sensors.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::sim {

struct SimOptions {
  double physics_dt_s = 0.001;   // 1 kHz physics
  double log_rate_hz = 100.0;
  double duration_s = 0.0;       // 0: until the mission is over (or max_duration_s)
  double max_duration_s = 900.0;
  double settle_after_landing_s = 1.0;  // keep logging this long after touchdown
  // false: the run goes on after the mission's landing until duration_s/max_duration_s or the caller
  // stops stepping (an external autopilot flies the motors through Plugins::command_hook).
  bool end_when_landed = true;
  uint64_t seed = 1;
  // "truth" (the controller reads the true state), "eskf" or "complementary".
  std::string estimator = "eskf";
  // true: the estimator runs and is logged, but the controller flies on the true state (to study
  // an estimator open-loop).
  bool control_on_truth = false;
  bool write_log = true;
  // > 0: the log also carries native-rate imu, rcou and batt streams at up to this rate (sim.stream_rate_hz;
  // sim/step_record.h LogRecorder::EnableStreams); 0: none, the outputs unchanged.
  double stream_rate_hz = 0.0;
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
  RunSummary summary;  // hexsim.summary/1 (ToJson writes summary.json)
  // OK, or kNumerical when the run diverged (the log and summary are still complete up to then).
  Status status;
};

// The vehicle's rigid body: mass (vehicle + payload_kg, the one place the total mass is formed),
// inertia, landing-gear box, ground friction.
RigidBodyParams BodyParamsFor(const vehicle::VehicleParams& vehicle, const WorldParams& world, double payload_kg);
// Height of the centre of mass above the ground plane when the landing gear stands on it (the
// simulator's take-off pose; the gap replay's ground-effect heights start from it).
double RestingHeight_m(const RigidBodyParams& body);

// Validates cross-file consistency (e.g. the date against the field model) before anything runs.
Status ValidateRunSetup(const RunSetup& setup);

// Flies the mission. Deterministic: same setup → same log, byte for byte. A thin wrapper:
// Simulation::Create(setup) → RunToEnd() → Finish().
RunOutput RunMission(const RunSetup& setup);

// Called after the mission sequencer, before the controller, on every autopilot tick: may rewrite
// the setpoint (e.g. a step or a chirp on one loop). `nav` is what the controller will read.
using SetpointHook = std::function<void(double t_s, const control::NavState& nav, control::Setpoint* setpoint)>;
// Called after the controller, before the mixer: may rewrite its output (actuator-point injection).
using OutputHook = std::function<void(double t_s, const control::NavState& nav, control::ControlOutput* output)>;
// Called last on every autopilot tick, after the mixer and the spool logic (control/spool.h) (also while the setpoint
// is idle): may rewrite the per-motor commands, which are then clamped to [0, 1] (a caller flying the
// motors directly, e.g. the Python bindings).
using CommandHook = std::function<void(double t_s, const control::NavState& nav, std::vector<double>* commands)>;

// What a caller plugs into the autopilot, given to Simulation::Create (the compass compensation is
// RunSetup::compensator). Every member is optional.
struct Plugins {
  // Replaces the built-in CascadedController (build it from ControlModelFor(setup.vehicle)).
  std::unique_ptr<control::Controller> controller;
  // Replaces the estimator SimOptions::estimator names (the run's "estimator" becomes its name());
  // it is Reset() with a static-alignment request at the start position.
  std::unique_ptr<nav::Estimator> estimator;
  SetpointHook setpoint_hook;
  OutputHook output_hook;
  CommandHook command_hook;
};

// The vehicle model the built-in controller is given (mass, inertia, the largest collective thrust
// at full charge): what a plug-in controller is built from.
control::VehicleModelForControl ControlModelFor(const vehicle::VehicleParams& vehicle);

// The closed loop as a steppable object, for controller development and response tools:
//
//   Plugins plugins;
//   plugins.controller = std::make_unique<MyController>(ControlModelFor(setup.vehicle));
//   auto sim = Simulation::Create(setup, std::move(plugins)).value();
//   while (sim->Step()) { ... sim->true_state() ... }
//   RunOutput out = sim->Finish();
//
// One Step() is one physics step (SimOptions::physics_dt_s), in stages (sim/src/stages.h): the
// sensors sample the truth; the autopilot runs on each fresh IMU sample (estimator ← compensated
// compass, sequencer, setpoint hook, controller, mixer); the observers (FlightLog recorder at the
// log rate, scorer; step_record.h) read the step's record; then physics advances (powertrain, rotor
// wrench and aerodynamics, drag, ODE). The hot path does not allocate (apart from log rows and the
// estimator's own work).
class Simulation {
 public:
  using SetpointHook = sim::SetpointHook;
  using OutputHook = sim::OutputHook;

  // Validates (ValidateRunSetup) and builds everything; the vehicle rests on the ground at t = 0.
  static Result<std::unique_ptr<Simulation>> Create(const RunSetup& setup, Plugins plugins = {});
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  // --- Disturbances ----------------------------------------------------------------------------
  // Sets the mean wind (NED, m/s) from now on, e.g. a gust step; turbulence stays as configured.
  void SetWindMean(const Eigen::Vector3d& wind_N_mps);
  // Adds (positive) or releases (negative) payload mass at the vehicle's payload attachment point.
  void ChangePayload(double delta_kg);
  // An extra force (NED, N) applied to the body at every step until changed (zero to stop).
  void SetExternalForce(const Eigen::Vector3d& force_N_N);

  // --- Stepping --------------------------------------------------------------------------------
  // One physics step. false when the run is over (mission done and settled, duration reached, or
  // diverged); further calls do nothing.
  bool Step();
  void RunToEnd();
  // Summary and log meta; the Simulation is spent afterwards (only accessors remain valid).
  RunOutput Finish();

  // --- State -----------------------------------------------------------------------------------
  double time_s() const;
  bool finished() const;
  const BodyState& true_state() const;
  const vehicle::SensorReadings& sensors() const;
  // The estimator's estimate (the truth when flying on truth).
  const nav::NavEstimate& estimate() const;
  // What the controller read, was asked and commanded at the last autopilot tick.
  const control::NavState& nav_state() const;
  const control::Setpoint& setpoint() const;
  const control::ControlOutput& control_output() const;
  const magnetics::Currents& currents() const;
  const std::vector<double>& motor_commands() const;
  // The powertrain's operating point over the last physics step (motor speeds, currents, bus
  // voltage); its motors are empty before the first step.
  const vehicle::PowertrainOutput& powertrain() const;
  // The true specific force (a - g, body) of the last physics step, as the accelerometer sees it
  // before its errors; and the battery's state of charge now.
  const Eigen::Vector3d& specific_force_B_mps2() const;
  double soc() const;
  // The FlightLog recorded so far (empty after Finish(), which hands it over).
  const logs::FlightLog& log() const;
  double payload_kg() const;
  const control::VehicleModelForControl& control_model() const;
  const RunSetup& setup() const;
  // The built-in controller (null when replaced), for its debug() values.
  const control::CascadedController* builtin_controller() const;

 private:
  struct Impl;
  explicit Simulation(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace hexsim::sim
