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
  double accel_mps2 = 2.0;              // carrot acceleration and braking along a segment
  double max_lead_m = 4.0;              // the carrot waits while it is this far ahead along the segment
  double ground_D_m = 0.0;              // ground level (NED D) where the vehicle lands
  double takeoff_acceptance_m = 0.5;    // vertical distance to the takeoff altitude that completes it
  double touchdown_speed_mps = 0.2;     // touchdown: speed below this ...
  double touchdown_height_m = 0.6;      // ... and within this of ground_D_m (or unable to follow the carrot down)
  double touchdown_time_s = 1.0;        // ... for this long
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

  // The first call takes the vehicle's position as the start of the mission.
  SequencerOutput Step(const NavState& state, double dt_s);

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
  double yaw_rad_ = 0.0;
  double timer_s_ = 0.0;
  bool holding_ = false;  // at a waypoint, waiting out its hold_s
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
