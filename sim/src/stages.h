// The three stages of the closed loop (private to sim/): each physics instant the sensors sample
// the truth, the autopilot runs on a fresh IMU sample, then physics advances the body by one step.
// Simulation::Impl (simulation.cc) owns one of each, calls them in that order, and hands a
// StepRecord to the observers (step_record.h) between the autopilot and physics.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hexsim/common/rotation.h"
#include "hexsim/control/controller.h"
#include "hexsim/control/mixer.h"
#include "hexsim/control/sequencer.h"
#include "hexsim/control/spool.h"
#include "hexsim/magnetics/wmm.h"
#include "hexsim/sim/mixer_geometry.h"
#include "hexsim/sim/simulation.h"
#include "hexsim/vehicle/powertrain.h"
#include "hexsim/vehicle/rotor_wrench.h"
#include "hexsim/vehicle/sensors.h"

namespace hexsim::sim {

// --- Sensors -------------------------------------------------------------------------------------
class SensorStage {
 public:
  SensorStage(const vehicle::VehicleParams& vp, uint64_t seed, const Eigen::Vector3d& B_earth_N_uT);
  // Samples the truth of instant t: the body state, the specific force of the last step and the
  // currents of the last powertrain operating point (avionics only before the first step).
  const vehicle::SensorReadings& Sample(double t, const BodyState& s, const Eigen::Vector3d& f_B,
                                        const vehicle::PowertrainOutput& pt);
  const vehicle::SensorReadings& readings() const { return *rd_; }
  const magnetics::Currents& currents() const { return truth_.currents; }

 private:
  std::optional<vehicle::SensorSuite> suite_;
  vehicle::SensorTruth truth_;
  double avionics_A_ = 0.0;
  vehicle::SensorReadings empty_;  // what readings() shows before the first sample
  const vehicle::SensorReadings* rd_ = &empty_;
};

// --- Autopilot: estimator ← compensated compass, sequencer, setpoint hook, controller, mixer ---
class Autopilot {
 public:
  Autopilot(const RunSetup& setup, Plugins plugins, const magnetics::EarthField& field, double rest_D_m,
            const Eigen::Vector3d& start_N_m);

  struct Tick {
    bool ran = false;  // a fresh IMU sample arrived and the autopilot ran
    std::optional<control::PayloadEvent> payload_event;
    const control::WaypointArrival* arrival = nullptr;
    std::string failure;  // non-empty: the estimator reported itself unhealthy (the run diverged)
  };
  // Runs on each fresh IMU sample; `bus_V` and `battery_A` are what the autopilot measures.
  Tick Step(double t, double physics_dt_s, const vehicle::SensorReadings& rd, const BodyState& s, double bus_V,
            double battery_A);

  const std::vector<double>& commands() const { return commands_; }
  double control_u() const { return control_u_; }
  const nav::NavEstimate& estimate() const { return est_; }
  const control::NavState& nav_state() const { return ns_; }
  const control::Setpoint& setpoint() const { return seq_out_.setpoint; }
  const control::ControlOutput& control_output() const { return u_; }
  const control::MissionSequencer& sequencer() const { return *sequencer_; }
  const std::vector<Eigen::Vector3d>& path() const { return path_; }
  const control::VehicleModelForControl& model() const { return model_; }
  const control::CascadedController* builtin() const { return builtin_; }
  bool estimated() const { return estimator_ != nullptr; }
  const std::string& estimator_name() const { return estimator_name_; }

 private:
  const vehicle::VehicleParams& vp_;
  const SimOptions& opt_;
  double nominal_V_ = 0.0;
  control::VehicleModelForControl model_;
  std::optional<control::Mixer> mixer_;
  control::Spool spool_;
  std::unique_ptr<control::Controller> controller_;
  control::CascadedController* builtin_ = nullptr;
  std::optional<control::MissionSequencer> sequencer_;
  std::vector<Eigen::Vector3d> path_;
  std::unique_ptr<nav::Estimator> estimator_;  // null: truth
  std::string estimator_name_;
  std::shared_ptr<const magnetics::Compensator> compensator_;
  SetpointHook setpoint_hook_;
  OutputHook output_hook_;
  CommandHook command_hook_;

  // Compass, GPS and baro samples arrive on their own clocks, usually between IMU ticks: each fresh
  // one is noted here and fused at the next tick, after the IMU prediction.
  bool pending_mag_ = false, pending_gps_ = false, pending_baro_ = false;
  double last_imu_t_s_ = -1.0;
  std::vector<double> commands_;
  control::MixResult mix_;  // kept across ticks: its storage is reused
  double control_u_ = 0.0;
  nav::NavEstimate est_;
  control::SequencerOutput seq_out_;
  control::NavState ns_;
  control::ControlOutput u_;
};

// --- Physics: powertrain, rotor and airframe forces, wind, ODE rigid body ------------------------
class PhysicsStage {
 public:
  PhysicsStage(const RunSetup& setup, uint64_t seed);

  // Advances the body by dt_s from t_s with the motor commands. Returns "" or, when the state left
  // the finite/plausible range, why (the run diverged; the state is then the last good one).
  std::string Advance(const std::vector<double>& commands, double t_s, double dt_s);
  void SetPayload_kg(double payload_kg);

  const BodyState& state() const { return s_; }
  const BodyState& start() const { return start_; }
  double rest_D_m() const { return rest_D_m_; }
  const Eigen::Vector3d& specific_force_B_mps2() const { return specific_force_B_; }
  // The operating point over the last step (motors empty before the first).
  const vehicle::PowertrainOutput& powertrain() const { return pt_; }
  double soc() const { return power_.soc; }
  double payload_kg() const { return payload_kg_; }
  const Eigen::Vector3d& wind_N_mps() const { return wind_->current_N_mps(); }
  void SetWindMean(const Eigen::Vector3d& wind_N_mps) { wind_->SetMean(wind_N_mps); }
  void SetExternalForce(const Eigen::Vector3d& f_N_N) { external_force_N_N_ = f_N_N; }
  const Eigen::Vector3d& previous_p_N_m() const { return p_prev_N_m_; }

 private:
  const vehicle::VehicleParams& vp_;
  const WorldParams& world_;
  vehicle::RotorWrenchTable rotor_wrench_;  // the rotors' per-rotor constants, folded once
  double payload_kg_ = 0.0;
  double rest_D_m_ = 0.0;
  BodyState start_;
  std::unique_ptr<RigidBodyWorld> body_;
  std::optional<WindModel> wind_;
  Eigen::Vector3d external_force_N_N_ = Eigen::Vector3d::Zero();
  vehicle::PowertrainState power_;
  vehicle::PowertrainOutput pt_;
  BodyState s_;  // the body's state now: read after construction and after every step
  Eigen::Vector3d p_prev_N_m_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d specific_force_B_ = Eigen::Vector3d(0, 0, -kGravity_mps2);
};

}  // namespace hexsim::sim
