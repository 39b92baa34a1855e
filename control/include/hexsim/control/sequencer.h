// Mission sequencer: a resolved Mission + the vehicle state → a Setpoint each step.
//
// Every move (takeoff climb, waypoint leg, landing descent) follows the straight segment from the
// previous target to the next: a carrot advances along it at the commanded speed (accelerating and
// braking at accel_mps2, waiting when it gets more than max_lead_m ahead of the vehicle), and the
// setpoint is the carrot's position with its velocity as feed-forward, so cross-track stays small.
// These segments are exactly those of PlannedPath(mission, start, ground), leg k = points k → k+1.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>

#include "hexsim/control/mission.h"
#include "hexsim/control/types.h"

namespace hexsim::control {

enum class FlightMode { kIdle = 0, kTakeoff = 1, kWaypoint = 2, kHold = 3, kLand = 4, kLanded = 5, kDone = 6 };
const char* FlightModeName(FlightMode mode);

struct SequencerParams {
  double climb_speed_mps = 2.5;         // takeoff (keep <= the controller's max_speed_up_mps)
  double descent_speed_mps = 1.2;       // landing, above final_descent_height_m
  double final_descent_speed_mps = 0.5;  // landing, below it
  double final_descent_height_m = 3.0;
  // A leg's speed is capped so that its vertical part stays within these (keep them <= the
  // controller's max_speed_up_mps / max_speed_down_mps, or climbing legs leave the straight line).
  double max_climb_mps = 3.0;
  double max_descent_mps = 1.5;
  double accel_mps2 = 2.0;              // carrot acceleration and braking along a segment (also
                                        // when a segment's speed drops, e.g. at final descent)
  // The yaw setpoint turns to each new heading at most this fast, accelerating and braking at
  // yaw_accel_dps2 (PX4 MPC_YAWRAUTO_MAX = 45 deg/s; ArduPilot shapes yaw with ATC_ACCEL_Y_MAX):
  // a heading step would otherwise ask the rotors of one spin direction for a step in speed.
  double yaw_rate_dps = 45.0;
  double yaw_accel_dps2 = 90.0;
  double max_lead_m = 4.0;              // the carrot waits while it is this far ahead along the segment
  // The carrot's acceleration rises at most this fast (ArduPilot PSC_JERK_XY/Z = 5 m/s^3): a step
  // in acceleration is a step in collective, which the rotors' inertia turns into a current spike.
  // Braking is not jerk-limited (it lowers the collective; a late brake overshoots the waypoint).
  double jerk_mps3 = 5.0;
  // The landing carrot descends until touchdown is detected, however far the altitude estimate is
  // off: its segment's end stays this far below it (first below ground_D_m), so it never brakes.
  // After touchdown the vertical loop keeps asking for descent and winds the collective down to its
  // minimum while the touchdown detector runs (ArduPilot descends at LAND_SPEED until its land
  // detector trips). A baro offset of a metre or two from the ground at take-off is ordinary.
  double land_lookahead_m = 1.0;
  double ground_D_m = 0.0;              // ground level (NED D) where the vehicle lands
  double takeoff_acceptance_m = 0.5;    // vertical distance to the takeoff altitude that completes it
  double touchdown_speed_mps = 0.2;     // touchdown: speed below this ...
  double touchdown_height_m = 0.6;      // ... and within this of ground_D_m (or unable to follow the carrot down)
  double touchdown_time_s = 1.0;        // ... for this long
  // ... or, as ArduPilot's land detector (collective at its lower limit, climb/descent below
  // LAND_DETECTOR_VEL_Z_MAX = 1 m/s, for 1 s), the collective below touchdown_collective_to_weight
  // of the weight and the vertical speed below touchdown_vertical_speed_mps, for touchdown_time_s:
  // robust to an estimate that drifts once the vehicle sits on the ground.
  double touchdown_vertical_speed_mps = 1.0;
  double touchdown_collective_to_weight = 0.25;
  // Lift-off needs the collective at least this fraction of the weight (when it is known): an
  // estimate drifting upwards on the ground is not a lift-off.
  double liftoff_collective_to_weight = 0.8;
  // Take-off from the ground (ArduPilot auto_takeoff_run while land_complete): the collective ramps
  // from 0 to full scale over takeoff_slew_time_s (TKOFF_SLEW_TIME) with the position loops reset,
  // until the vehicle climbs at liftoff_climb_fraction of climb_speed_mps (as ArduPilot's "desired
  // velocity > 10 % of the maximum climb rate" after init_z_controller) or the ramp reaches
  // takeoff_throttle_max (TKOFF_THR_MAX); then the climb segment is flown from where it is.
  double takeoff_slew_time_s = 2.0;
  double takeoff_throttle_max = 0.9;
  double liftoff_climb_fraction = 0.1;
};

struct PayloadEvent {
  PayloadAction action = PayloadAction::kAttach;
  double mass_kg = 0.0;
  double t_s = 0.0;
  int item_index = 0;
};

struct WaypointArrival {
  int waypoint_index = 0;  // 0-based among the mission's waypoint items
  double t_s = 0.0;
  double error_m = 0.0;    // distance to the waypoint when it was accepted
};

struct SequencerOutput {
  Setpoint setpoint;
  std::optional<PayloadEvent> payload_event;  // for the simulator to apply this step
  std::optional<WaypointArrival> arrival;
};

class MissionSequencer {
 public:
  // `mission` must be resolved (ResolveMission); checked.
  explicit MissionSequencer(Mission mission, SequencerParams params = {});

  // The first call takes the vehicle's position as the start of the mission. `motors_ready`: the
  // output stage has spooled up (control/spool.h), so a take-off's ground ramp may advance.
  // `collective_to_weight`: the last collective over the vehicle's weight (< 0: unknown), which
  // tells lift-off (only possible near or above 1) and touchdown (far below 1: something else
  // carries the weight) from an estimate's drift.
  SequencerOutput Step(const NavState& state, double dt_s, bool motors_ready = true,
                       double collective_to_weight = -1.0);

  FlightMode mode() const { return mode_; }
  const char* mode_name() const { return FlightModeName(mode_); }
  int item_index() const { return item_; }          // items.size() once the mission is over
  int waypoint_index() const { return waypoint_; }  // current/last waypoint, −1 before the first
  int active_leg() const { return leg_; }           // segment of PlannedPath being flown, −1 before the first
  bool landed() const { return landed_; }
  bool done() const { return mode_ == FlightMode::kDone; }
  const Mission& mission() const { return mission_; }

 private:
  void BeginItem(size_t index, const NavState& state, SequencerOutput* out);
  void BeginSegment(const Eigen::Vector3d& end, double speed_mps);
  // Moves the carrot; true when it has reached the end of the segment.
  bool AdvanceCarrot(const NavState& state, double speed_mps, double dt_s, Setpoint* sp);
  void HoldAt(const Eigen::Vector3d& p, Setpoint* sp) const;
  // Moves the shaped yaw setpoint towards yaw_rad_ (rate and acceleration limited).
  void ShapeYaw(double dt_s);
  // A take-off's ground ramp; true while the vehicle is still on the ground (*sp is the ramp).
  bool GroundRamp(const NavState& state, double dt_s, bool motors_ready, double collective_to_weight, Setpoint* sp);

  Mission mission_;
  SequencerParams params_;
  FlightMode mode_ = FlightMode::kIdle;
  bool started_ = false;
  bool landed_ = true;
  int item_ = -1;
  int waypoint_ = -1;
  int leg_ = -1;
  Eigen::Vector3d target_ = Eigen::Vector3d::Zero();  // the last reached (or current hold) target
  Eigen::Vector3d seg_start_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d seg_end_ = Eigen::Vector3d::Zero();
  double seg_speed_mps_ = 0.0;
  double carrot_s_m_ = 0.0;
  double carrot_v_mps_ = 0.0;
  double carrot_a_mps2_ = 0.0;
  double yaw_rad_ = 0.0;          // the heading wanted
  double yaw_sp_rad_ = 0.0;       // the shaped yaw setpoint, turning towards yaw_rad_
  double yaw_rate_radps_ = 0.0;   // its rate
  double timer_s_ = 0.0;
  bool holding_ = false;  // at a waypoint, waiting out its hold_s
  bool ground_ramp_ = false;  // a take-off from the ground, before lift-off
  double ground_thrust_fraction_ = 0.0;
};

// The planned path: start, the takeoff point (start N/E at the takeoff altitude), every waypoint, and
// each landing point (previous N/E at ground_D_m). Hold and payload items add no point.
std::vector<Eigen::Vector3d> PlannedPath(const Mission& mission, const Eigen::Vector3d& start_p_N_m,
                                         double ground_D_m = 0.0);
// Distance from p to the segment path[leg] → path[leg+1] (the active leg; MissionSequencer::active_leg).
double CrossTrackToLeg(const std::vector<Eigen::Vector3d>& path, int leg, const Eigen::Vector3d& p_N_m);
// Distance from p to the nearest segment of the whole polyline (the leg-independent figure, used
// when the active leg is not known, e.g. for logs of real flights).
double CrossTrack(const std::vector<Eigen::Vector3d>& path, const Eigen::Vector3d& p_N_m);

}  // namespace hexsim::control
