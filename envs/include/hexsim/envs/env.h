// One environment: the episode logic behind hexsim's Python environments (HoverEnv, WaypointEnv,
// CompassWaypointEnv), so that a vector of them steps in C++ and Python holds none of it.
//
// An episode: a fresh sim::Simulation from the episode's simulation seed; once the estimator has
// aligned on the ground (at once on truth), the built-in cascade takes off and settles at the start
// point (target_N_m plus an offset drawn in ±start_offset_m per axis; settle_s in all, not part of
// the episode); then the agent acts every control_period_s.
// Seeding: Reset(seed) starts the env's episode stream RngStream(seed, "envs.episode"); every
// episode (Reset(seed) or the next Reset()) draws its simulation seed and its start offset from it.
// The same seed gives the same episodes, whichever vector or thread steps the env.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexsim/common/rng.h"
#include "hexsim/common/status.h"
#include "hexsim/envs/act.h"
#include "hexsim/sim/simulation.h"

namespace hexsim::envs {

enum class Task { kHover, kWaypoint, kCompassWaypoint };
// What the observation is made of: the true state; the onboard estimator's state; or the raw
// sensors the autopilot reads (IMU, compensated compass, GPS, baro, battery current).
enum class ObsSource { kTruth, kEstimator, kSensors };

struct EnvOptions {
  Task task = Task::kHover;
  ActMode act = ActMode::kMotors;  // motors, rates or attitude
  ObsSource observe = ObsSource::kTruth;
  // Hover: the point held. Waypoint, CompassWaypoint: the take-off hover point the first leg starts from.
  Eigen::Vector3d target_N_m = Eigen::Vector3d(0.0, 0.0, -5.0);
  std::vector<Eigen::Vector3d> waypoints_N_m;  // Waypoint, CompassWaypoint: flown in order
  double acceptance_m = 1.0;        // a waypoint is reached within this distance (hover: success)
  double time_limit_s = 10.0;       // agent time; then truncated
  double control_period_s = 0.01;   // one agent step; a whole number of physics steps
  double settle_s = 6.0;
  double start_offset_m = 0.5;
  double max_rate_radps = 3.141592653589793;  // rates action scale
  double max_tilt_rad = 0.6108652381980153;   // attitude action scale (35°)
  double ground_margin_m = 0.3;     // terminated below this height above the ground at take-off
  double terminate_tilt_deg = 60.0;
  // Hover, Waypoint: −(|position error|² + rate_weight·|w_B|²) per step (m², (rad/s)²).
  double rate_weight = 0.1;
  // CompassWaypoint: −(cross_track_weight·xt² + effort_weight·Σ(u_i − u_hover)²) + progress_weight·Δalong
  // per step (xt, along in m; u motor commands 0..1).
  double cross_track_weight = 1.0;
  double effort_weight = 1.0;
  double progress_weight = 1.0;
  Status Validate() const;  // bad input names the field
};

// The vehicle as a motors-mode controller needs it. Mixer: [thrust_N; τ_B (N·m)] = A·t, t = rotor
// thrusts (N), A 4×N (control/mixer.h).
struct VehicleLayout {
  size_t rotors = 0;
  std::vector<Eigen::Vector3d> rotor_p_B_m;  // rotor positions, body FRD
  std::vector<int> spin;                     // +1 counter-clockwise seen from above
  Eigen::MatrixXd mixer;                     // A, 4×N
  double mass_kg = 0.0;
  Eigen::Matrix3d inertia_kgm2 = Eigen::Matrix3d::Zero();  // body FRD, about the centre of mass
  double hover_thrust_N = 0.0;  // m·g
  double max_thrust_N = 0.0;    // largest collective at full charge
  double hover_command = 0.0;   // the equal motor command (0..1) whose thrust is m·g at full charge
};
VehicleLayout LayoutOf(const sim::RunSetup& setup);

// Info per step: the truth the agent does not observe (and the judge's figures), by index.
enum InfoField : int {
  kInfoTime = 0,         // t_s, agent time since the episode began
  kInfoPositionError,    // position_error_m, |target − p| (true)
  kInfoBatteryA,         // battery_A
  kInfoTiltDeg,          // tilt_deg (true)
  kInfoHeightM,          // height_m above the take-off ground
  kInfoWaypointIndex,    // waypoint_index (0 for Hover)
  kInfoIsSuccess,        // is_success: 1 when the last waypoint is reached (Hover: the time limit
                         // reached within acceptance_m)
  kInfoCrossTrackM,      // cross_track_m: horizontal distance from the current leg (true; Hover: 0)
  kInfoYawTrueDeg,       // yaw_true_deg
  kInfoYawEstDeg,        // yaw_est_deg (the estimator's)
  kInfoYawErrorDeg,      // yaw_error_deg: estimated − true, wrapped to ±180
  kInfoTrueN, kInfoTrueE, kInfoTrueD,  // true_p_N_m, true_p_E_m, true_p_D_m
  kInfoSize
};
extern const std::array<const char*, kInfoSize> kInfoNames;

struct StepOutput {
  double reward = 0.0;
  bool terminated = false;
  bool truncated = false;
};

class Env {
 public:
  // `setup` as `hexsim run` loads it (with its calibration attached); its options' seed and duration
  // are set per episode.
  static Result<std::unique_ptr<Env>> Create(const sim::RunSetup& setup, const EnvOptions& options);

  size_t observation_size() const { return obs_size_; }
  size_t action_size() const { return action_low_.size(); }
  const std::vector<double>& action_low() const { return action_low_; }
  const std::vector<double>& action_high() const { return action_high_; }
  const VehicleLayout& layout() const { return layout_; }
  const EnvOptions& options() const { return options_; }

  // A new episode stream from `seed`, then its first episode. Writes the observation.
  Status Reset(uint64_t seed, double* obs);
  // The next episode of the current stream. Writes the observation.
  Status Reset(double* obs);
  // One agent step: `action` (action_size(), clipped to its bounds) held for control_period_s.
  // Writes the observation. The episode must be running (episode_over() false).
  StepOutput Step(const double* action, double* obs);
  bool episode_over() const { return over_; }
  // The simulation seed of the current episode.
  uint64_t episode_sim_seed() const { return sim_seed_; }
  void Info(double* info) const;  // kInfoSize values
  const sim::Simulation* simulation() const { return sim_.get(); }
  sim::Simulation* simulation() { return sim_.get(); }
  int steps_per_action() const { return steps_per_action_; }
  double agent_dt_s() const { return steps_per_action_ * setup_.options.physics_dt_s; }

 private:
  Env(const sim::RunSetup& setup, const EnvOptions& options);
  Status BeginEpisode(double* obs);
  void Observe(double* obs) const;
  void ApplyAction(const double* action);
  Eigen::Vector3d Target() const;
  Eigen::Vector3d LegStart() const;
  double CrossTrack(const Eigen::Vector3d& p_N_m, double* along_m) const;
  size_t WaypointCount() const;

  sim::RunSetup setup_;
  EnvOptions options_;
  VehicleLayout layout_;
  size_t obs_size_ = 0;
  std::vector<double> action_low_, action_high_;
  std::vector<double> clipped_;
  int steps_per_action_ = 10;
  RngStream stream_;
  std::unique_ptr<Action> action_;  // heap: the plug-ins hold its address
  std::unique_ptr<sim::Simulation> sim_;
  uint64_t sim_seed_ = 0;
  double t0_s_ = 0.0;
  double ground_D_m_ = 0.0;
  size_t index_ = 0;     // current waypoint
  double along_m_ = 0.0;  // CompassWaypoint: progress along the current leg
  bool over_ = true;
  bool success_ = false;
};

}  // namespace hexsim::envs
