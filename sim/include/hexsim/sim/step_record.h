// What one step of the closed loop did, as the observers of a run see it: the run loop
// (sensors → autopilot → physics, sim/src/) fills a StepRecord at every physics instant and a
// StepInterval after every physics step, and the observers (the FlightLog recorder and the scorer
// below, or a caller's own) read nothing else. Plain data: an observer is testable without ODE.
#pragma once

#include <cmath>

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "hexsim/control/sequencer.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/nav/estimator.h"
#include "hexsim/sim/rigid_body.h"
#include "hexsim/sim/run_summary.h"
#include "hexsim/vehicle/powertrain.h"
#include "hexsim/vehicle/sensors.h"

namespace hexsim::sim {

// The instant t_s = step * dt, after the sensors sampled and the autopilot ran, before physics.
// Pointers are owned by the run loop and valid during the observer call.
struct StepRecord {
  int64_t step = 0;
  double t_s = 0.0;
  const BodyState* truth = nullptr;
  const vehicle::SensorReadings* readings = nullptr;
  const nav::NavEstimate* estimate = nullptr;  // the truth when flying on truth
  bool estimated = false;                      // an estimator runs (false: flying on truth)
  const std::vector<double>* commands = nullptr;  // per motor, 0..1, as the autopilot left them
  double control_u = 0.0;                         // the paper's control amount of `commands`
  // The operating point over the last physics step (motors empty before the first one).
  const vehicle::PowertrainOutput* powertrain = nullptr;
  double battery_A = 0.0;      // battery current the sensors saw (avionics only before the first step)
  double soc = 1.0;            // battery state of charge now
  double nominal_V = 0.0;      // bus voltage before the first step (open circuit at the initial SoC)
  Eigen::Vector3d wind_N_mps = Eigen::Vector3d::Zero();
  control::FlightMode mode = control::FlightMode::kIdle;
  int waypoint_index = -1;
  int active_leg = -1;
  bool landed = true;
  double payload_kg = 0.0;
  const control::WaypointArrival* arrival = nullptr;  // accepted at this instant
};

// One physics step [t_s, t_s + dt_s], after it succeeded.
struct StepInterval {
  double t_s = 0.0;
  double dt_s = 0.0;
  const vehicle::PowertrainOutput* powertrain = nullptr;  // the operating point that acted over it
  Eigen::Vector3d p_before_N_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_after_N_m = Eigen::Vector3d::Zero();
};

// Writes the FlightLog columns (CONTRACTS "FlightLog") every `log_every`-th step.
class LogRecorder {
 public:
  LogRecorder(logs::FlightLog* log, size_t rotors, size_t compasses, int log_every);
  void OnStep(const StepRecord& r);
  size_t time_column() const { return t_; }
  // Native-rate streams (CONTRACTS, real data; FlightLog::Stream), as an autopilot logs them:
  //   imu   gyro_*_radps, accel_*_mps2 at each IMU sample's own time stamp
  //   rcou  motor_i_u at the instant the autopilot's commands are read
  //   batt  current_A (sensed), voltage_V (bus)
  // each kept when at least 1/rate_hz after the last kept sample of its stream (rate_hz above the
  // sensor rate keeps every sample). Off unless enabled; AttachStreams hands them to the log.
  void EnableStreams(double rate_hz);
  void AttachStreams();

 private:
  logs::FlightLog* log_;
  int log_every_;
  size_t t_ = 0, pos_[3] = {}, vel_[3] = {}, q_[4] = {}, gyro_[3] = {}, accel_[3] = {}, baro_ = 0, baro_t_ = 0;
  size_t gps_[3] = {}, gps_vel_[3] = {}, gps_t_ = 0, control_u_ = 0, current_ = 0, voltage_ = 0, soc_ = 0;
  std::vector<size_t> motor_u_, motor_A_;
  size_t esc_limited_ = 0, batt_limited_ = 0;
  std::vector<std::array<size_t, 4>> mag_;  // x, y, z, t per compass
  size_t est_q_[4] = {}, est_pos_[3] = {}, est_vel_[3] = {}, yaw_true_ = 0, yaw_est_ = 0, mode_ = 0, wp_ = 0;
  size_t wind_[3] = {}, payload_ = 0;
  struct Stream {
    logs::FlightLog table;
    double next_t_s = -1.0;  // earliest time of the next kept sample
    bool Due(double t_s, double period_s);
  };
  double stream_period_s_ = -1.0;  // < 0: no streams
  Stream imu_, rcou_, batt_;
};

// Running max/RMS/mean of one quantity.
struct RunningStats {
  double n = 0, sum = 0, sum2 = 0, max = 0;  // max of |x|
  void Add(double x);
  double Rms() const;
  double Mean() const;
};

// The run's scores (summary.json): cross-track and yaw error on the mission legs, yaw error over
// the whole flight, energy, battery current, distance, waypoint arrivals.
class RunScorer {
 public:
  // `path`: the planned path (control::PlannedPath) whose legs cross-track is measured against.
  explicit RunScorer(std::vector<Eigen::Vector3d> path) : path_(std::move(path)) {}
  void OnStep(const StepRecord& r);
  void OnInterval(const StepInterval& iv);
  // Adds distance_m, cross_track_m, yaw_error_deg, yaw_error_all_deg, energy_Wh, current_A,
  // current_limited_s, waypoints (hexsim.summary/1).
  void WriteSummary(RunSummary* summary) const;

  const RunningStats& cross_track_m() const { return cross_track_; }
  const RunningStats& yaw_error_deg() const { return yaw_err_; }
  const RunningStats& yaw_error_all_deg() const { return yaw_err_all_; }
  const RunningStats& battery_A() const { return current_; }
  double energy_J() const { return energy_J_; }
  double distance_m() const { return distance_m_; }

 private:
  std::vector<Eigen::Vector3d> path_;
  RunningStats cross_track_, yaw_err_, yaw_err_all_, current_;
  double energy_J_ = 0.0, distance_m_ = 0.0;
  double esc_limited_s_ = 0.0, battery_limited_s_ = 0.0;  // time with an ESC / the battery at its limit
  std::vector<WaypointArrival> arrivals_;
  // YawDegFast(est_q_): the yaw of the last estimate seen (bitwise compared; NaN: none yet).
  Eigen::Quaterniond est_q_{std::nan(""), 0.0, 0.0, 0.0};
  double est_yaw_deg_ = 0.0;
};

// YawDeg(q) bit for bit (common/rotation), without the roll and pitch EulerFromQuat also evaluates.
double YawDegFast(const Eigen::Quaterniond& q);

}  // namespace hexsim::sim
