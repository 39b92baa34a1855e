#include "hexsim/control/sequencer.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "hexsim/common/rotation.h"
#include "hexsim/common/status.h"

namespace hexsim::control {

using Eigen::Vector3d;

namespace {

// The speed from which a profile braking at `accel` still stops within `distance` once this step
// has moved it on by speed*dt: v^2 = 2*accel*(distance - v*dt), v = -accel*dt + sqrt((accel*dt)^2 +
// 2*accel*distance). The plain sqrt(2*accel*distance) of the distance before the step lags the
// profile by one step: the speed change it makes in a step is accel*(the previous step's dt), so
// with the autopilot's uneven ticks (a 400 Hz IMU on a 1 ms physics step: 2 and 3 ms) the
// acceleration feed-forward alternated between 2/3 and 3/2 of accel, and the collective with it,
// tick by tick.
double StoppingSpeed(double accel, double distance, double dt_s) {
  const double ad = accel * std::max(dt_s, 0.0);
  return std::sqrt(ad * ad + 2.0 * accel * std::max(distance, 0.0)) - ad;
}

}  // namespace

const char* FlightModeName(FlightMode mode) {
  switch (mode) {
    case FlightMode::kIdle: return "idle";
    case FlightMode::kTakeoff: return "takeoff";
    case FlightMode::kWaypoint: return "waypoint";
    case FlightMode::kHold: return "hold";
    case FlightMode::kLand: return "land";
    case FlightMode::kLanded: return "landed";
    case FlightMode::kDone: return "done";
  }
  return "?";
}

MissionSequencer::MissionSequencer(Mission mission, SequencerParams params)
    : mission_(std::move(mission)), params_(params) {
  HEXSIM_CHECK(mission_.resolved);
}

void MissionSequencer::BeginSegment(const Vector3d& end, double speed_mps) {
  seg_start_ = target_;
  seg_end_ = end;
  seg_speed_mps_ = speed_mps;
  carrot_s_m_ = 0.0;
  carrot_v_mps_ = 0.0;
  carrot_a_mps2_ = 0.0;
  ++leg_;
}

void MissionSequencer::HoldAt(const Vector3d& p, Setpoint* sp) const {
  sp->p_N_m = p;
  sp->v_ff_N_mps.setZero();
  sp->yaw_rad = yaw_sp_rad_;
  sp->yaw_rate_ff_radps = yaw_rate_radps_;
  sp->idle = false;
}

void MissionSequencer::ShapeYaw(double dt_s) {
  const double rate_max = params_.yaw_rate_dps * kDegToRad;
  const double accel = params_.yaw_accel_dps2 * kDegToRad;
  const double e = WrapPi(yaw_rad_ - yaw_sp_rad_);
  // Rate that still stops at the heading when braking at `accel` after this step, capped.
  const double wanted = std::copysign(std::min(rate_max, StoppingSpeed(accel, std::abs(e), dt_s)), e);
  yaw_rate_radps_ = std::clamp(wanted, yaw_rate_radps_ - accel * dt_s, yaw_rate_radps_ + accel * dt_s);
  if (std::abs(e) < 1e-4 && std::abs(yaw_rate_radps_) <= accel * dt_s) {
    yaw_sp_rad_ = yaw_rad_;  // arrived
    yaw_rate_radps_ = 0.0;
    return;
  }
  yaw_sp_rad_ = WrapPi(yaw_sp_rad_ + yaw_rate_radps_ * dt_s);
}

void MissionSequencer::BeginItem(size_t index, const NavState& state, SequencerOutput* out) {
  item_ = static_cast<int>(index);
  holding_ = false;
  if (index >= mission_.items.size()) {
    mode_ = FlightMode::kDone;
    return;
  }
  const MissionItem& it = mission_.items[index];
  switch (it.type) {
    case MissionItemType::kTakeoff:
      mode_ = FlightMode::kTakeoff;
      ground_ramp_ = landed_;
      ground_thrust_fraction_ = 0.0;
      landed_ = false;
      BeginSegment(Vector3d(target_.x(), target_.y(), -it.alt_m), params_.climb_speed_mps);
      break;
    case MissionItemType::kWaypoint: {
      mode_ = FlightMode::kWaypoint;
      ++waypoint_;
      const Vector3d d = it.p_N_m - target_;
      double speed = it.speed_mps.value_or(mission_.speed_mps);
      if (d.norm() > 1e-9) {
        const double vertical_fraction = std::abs(d.z()) / d.norm();
        const double v_limit = d.z() < 0.0 ? params_.max_climb_mps : params_.max_descent_mps;
        if (speed * vertical_fraction > v_limit) speed = v_limit / vertical_fraction;
      }
      BeginSegment(it.p_N_m, speed);
      if (it.yaw_deg) {
        yaw_rad_ = WrapPi(*it.yaw_deg * kDegToRad);
      } else if (mission_.yaw_mode == YawMode::kTravel && d.head<2>().norm() > 1.0) {
        yaw_rad_ = std::atan2(d.y(), d.x());
      }
      break;
    }
    case MissionItemType::kHold:
      mode_ = FlightMode::kHold;
      timer_s_ = it.duration_s;
      break;
    case MissionItemType::kPayload:
      // Applied at once (the simulator gets the event this step); then a zero-length hold at the
      // current target, so that at most one payload event leaves per step.
      mode_ = FlightMode::kHold;
      timer_s_ = 0.0;
      out->payload_event = PayloadEvent{it.action, it.mass_kg, state.t_s, item_};
      break;
    case MissionItemType::kLand:
      mode_ = FlightMode::kLand;
      BeginSegment(Vector3d(target_.x(), target_.y(), params_.ground_D_m + params_.land_lookahead_m),
                   params_.descent_speed_mps);
      timer_s_ = 0.0;
      break;
  }
}

bool MissionSequencer::GroundRamp(const NavState& state, double dt_s, bool motors_ready, double collective_to_weight,
                                   Setpoint* sp) {
  if (motors_ready) {
    ground_thrust_fraction_ = std::min(1.0, ground_thrust_fraction_ + dt_s / params_.takeoff_slew_time_s);
  }
  const double climb_mps = -state.v_N_mps.z();
  const bool can_lift = collective_to_weight < 0.0 || collective_to_weight >= params_.liftoff_collective_to_weight;
  const bool lifted = motors_ready && can_lift && climb_mps >= params_.liftoff_climb_fraction * seg_speed_mps_;
  if (!lifted && ground_thrust_fraction_ < params_.takeoff_throttle_max) {
    HoldAt(seg_start_, sp);
    sp->ground_ramp = true;
    sp->ground_thrust_fraction = ground_thrust_fraction_;
    return true;
  }
  // Lift-off: the carrot starts at the vehicle's height along the climb, at its climb rate.
  ground_ramp_ = false;
  const Vector3d d = seg_end_ - seg_start_;
  const double length = d.norm();
  if (length > 1e-9) carrot_s_m_ = std::clamp((state.p_N_m - seg_start_).dot(d / length), 0.0, length);
  carrot_v_mps_ = std::clamp(climb_mps, 0.0, seg_speed_mps_);
  return false;
}

bool MissionSequencer::AdvanceCarrot(const NavState& state, double speed_mps, double dt_s, Setpoint* sp) {
  const Vector3d d = seg_end_ - seg_start_;
  const double length = d.norm();
  const Vector3d dir = length > 1e-9 ? Vector3d(d / length) : Vector3d::Zero();
  const double along_m = (state.p_N_m - seg_start_).dot(dir);
  const double remaining_m = length - carrot_s_m_;
  // Speed profile: accelerate at accel, brake to stop at the end (StoppingSpeed); a lower
  // segment speed is reached by braking at accel too. Speeding up, the acceleration rises by at
  // most jerk*dt per step (a step in acceleration is a step in collective); braking is not
  // jerk-limited (it lowers the collective, and a late brake would overshoot the waypoint).
  const double a_max = params_.accel_mps2;
  const double v_brake = StoppingSpeed(a_max, remaining_m, dt_s);
  const double dv = a_max * dt_s;
  double v = std::min(v_brake, std::clamp(speed_mps, carrot_v_mps_ - dv, carrot_v_mps_ + dv));
  if (carrot_s_m_ - along_m > params_.max_lead_m) v = std::min(v, std::max(0.0, carrot_v_mps_ - dv));
  double a = dt_s > 0.0 ? (v - carrot_v_mps_) / dt_s : 0.0;
  if (a > 0.0 && a > carrot_a_mps2_ + params_.jerk_mps3 * dt_s) {
    a = std::max(0.0, carrot_a_mps2_) + params_.jerk_mps3 * dt_s;
    v = carrot_v_mps_ + a * dt_s;
  }
  carrot_a_mps2_ = a;
  carrot_v_mps_ = v;
  carrot_s_m_ = std::min(length, carrot_s_m_ + v * dt_s);
  const bool at_end = carrot_s_m_ >= length - 1e-9;
  sp->p_N_m = seg_start_ + carrot_s_m_ * dir;
  sp->v_ff_N_mps = at_end ? Vector3d::Zero() : Vector3d(v * dir);
  sp->a_ff_N_mps2 = at_end ? Vector3d::Zero() : Vector3d(a * dir);
  sp->yaw_rad = yaw_sp_rad_;
  sp->yaw_rate_ff_radps = yaw_rate_radps_;
  sp->idle = false;
  return at_end;
}

SequencerOutput MissionSequencer::Step(const NavState& state, double dt_s, bool motors_ready,
                                       double collective_to_weight) {
  SequencerOutput out;
  if (!started_) {
    started_ = true;
    target_ = state.p_N_m;
    yaw_rad_ = EulerFromQuat(state.q_NB).z();
    yaw_sp_rad_ = yaw_rad_;
    BeginItem(0, state, &out);
  }
  ShapeYaw(dt_s);
  Setpoint& sp = out.setpoint;
  switch (mode_) {
    case FlightMode::kIdle:
      sp.idle = true;
      break;
    case FlightMode::kLanded:
      sp.idle = true;
      timer_s_ -= dt_s;
      if (timer_s_ <= 0.0) BeginItem(static_cast<size_t>(item_) + 1, state, &out);
      break;
    case FlightMode::kDone:
      if (landed_) {
        sp.idle = true;
      } else {
        HoldAt(target_, &sp);
      }
      break;
    case FlightMode::kTakeoff: {
      if (ground_ramp_ && GroundRamp(state, dt_s, motors_ready, collective_to_weight, &sp)) break;
      const bool at_end = AdvanceCarrot(state, seg_speed_mps_, dt_s, &sp);
      if (at_end && std::abs(state.p_N_m.z() - seg_end_.z()) < params_.takeoff_acceptance_m) {
        target_ = seg_end_;
        BeginItem(static_cast<size_t>(item_) + 1, state, &out);
      }
      break;
    }
    case FlightMode::kWaypoint: {
      if (holding_) {
        HoldAt(target_, &sp);
        timer_s_ -= dt_s;
        if (timer_s_ <= 0.0) BeginItem(static_cast<size_t>(item_) + 1, state, &out);
        break;
      }
      const bool at_end = AdvanceCarrot(state, seg_speed_mps_, dt_s, &sp);
      const double error_m = (state.p_N_m - seg_end_).norm();
      if (at_end && error_m < mission_.acceptance_radius_m) {
        target_ = seg_end_;
        out.arrival = WaypointArrival{waypoint_, state.t_s, error_m};
        const double hold_s = mission_.items[static_cast<size_t>(item_)].hold_s;
        if (hold_s > 0.0) {
          holding_ = true;
          timer_s_ = hold_s;
        } else {
          BeginItem(static_cast<size_t>(item_) + 1, state, &out);
        }
      }
      break;
    }
    case FlightMode::kHold:
      HoldAt(target_, &sp);
      timer_s_ -= dt_s;
      if (timer_s_ <= 0.0) BeginItem(static_cast<size_t>(item_) + 1, state, &out);
      break;
    case FlightMode::kLand: {
      const double height_m = params_.ground_D_m - state.p_N_m.z();
      const double speed =
          height_m > params_.final_descent_height_m ? params_.descent_speed_mps : params_.final_descent_speed_mps;
      // The descent has no end short of touchdown (ArduPilot descends at LAND_SPEED until its land
      // detector trips): the segment's end moves down to stay land_lookahead_m below the carrot, so
      // an altitude estimate that is off by metres (a baro offset, GPS height) still reaches the
      // ground instead of hovering at a target it believes is below it.
      const Vector3d d = seg_end_ - seg_start_;
      const Vector3d carrot_N_m = d.norm() > 1e-9 ? Vector3d(seg_start_ + carrot_s_m_ * d.normalized()) : seg_start_;
      seg_end_.z() = std::max(seg_end_.z(), carrot_N_m.z() + params_.land_lookahead_m);
      const bool at_end = AdvanceCarrot(state, speed, dt_s, &sp);
      // Touchdown: (nearly) still, and either near the ground or unable to follow the carrot down;
      // or the collective far below the weight while the vertical speed is small.
      const bool still = state.v_N_mps.norm() < params_.touchdown_speed_mps;
      const bool near_ground = height_m < params_.touchdown_height_m;
      const bool blocked = at_end || sp.p_N_m.z() - state.p_N_m.z() > params_.touchdown_height_m;
      const bool carried = collective_to_weight >= 0.0 &&
                           collective_to_weight < params_.touchdown_collective_to_weight &&
                           std::abs(state.v_N_mps.z()) < params_.touchdown_vertical_speed_mps;
      const bool contact = carrot_s_m_ > 0.0 && ((still && (near_ground || blocked)) || carried);
      timer_s_ = contact ? timer_s_ + dt_s : 0.0;
      if (contact) {
        // On the ground, probably: hold the vehicle's own yaw and where it stands, and let the
        // controller relax (ArduPilot's land_complete_maybe: soften_for_landing_xy moves the
        // horizontal target to the current position). A horizontal target the vehicle cannot reach
        // while its legs grip the ground would tilt it about a leg until it tips over.
        sp.p_N_m.head<2>() = state.p_N_m.head<2>();
        sp.v_ff_N_mps.head<2>().setZero();
        sp.a_ff_N_mps2.head<2>().setZero();
        yaw_rad_ = yaw_sp_rad_ = EulerFromQuat(state.q_NB).z();
        yaw_rate_radps_ = 0.0;
        sp.yaw_rad = yaw_sp_rad_;
        sp.yaw_rate_ff_radps = 0.0;
        sp.ground_contact = true;
      }
      if (timer_s_ >= params_.touchdown_time_s) {
        landed_ = true;
        target_ = Vector3d(state.p_N_m.x(), state.p_N_m.y(), params_.ground_D_m);
        mode_ = FlightMode::kLanded;
        timer_s_ = params_.touchdown_time_s;  // motors off; stay landed this long before the next item
        sp = Setpoint();
        sp.idle = true;
      }
      break;
    }
  }
  return out;
}

std::vector<Vector3d> PlannedPath(const Mission& mission, const Vector3d& start_p_N_m, double ground_D_m) {
  std::vector<Vector3d> path{start_p_N_m};
  for (const MissionItem& it : mission.items) {
    const Vector3d& last = path.back();
    switch (it.type) {
      case MissionItemType::kTakeoff: path.emplace_back(last.x(), last.y(), -it.alt_m); break;
      case MissionItemType::kWaypoint: path.push_back(it.p_N_m); break;
      case MissionItemType::kLand: path.emplace_back(last.x(), last.y(), ground_D_m); break;
      default: break;
    }
  }
  return path;
}

namespace {
double SegmentDistance(const Vector3d& a, const Vector3d& b, const Vector3d& p) {
  const Vector3d ab = b - a;
  const double l2 = ab.squaredNorm();
  const double t = l2 > 0.0 ? std::clamp((p - a).dot(ab) / l2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}
}  // namespace

double CrossTrackToLeg(const std::vector<Vector3d>& path, int leg, const Vector3d& p_N_m) {
  if (path.empty()) return 0.0;
  if (path.size() == 1) return (path[0] - p_N_m).norm();
  const int k = std::clamp(leg, 0, static_cast<int>(path.size()) - 2);
  return SegmentDistance(path[static_cast<size_t>(k)], path[static_cast<size_t>(k) + 1], p_N_m);
}

double CrossTrack(const std::vector<Vector3d>& path, const Vector3d& p_N_m) {
  if (path.size() < 2) return CrossTrackToLeg(path, 0, p_N_m);
  double best = std::numeric_limits<double>::infinity();
  for (size_t k = 0; k + 1 < path.size(); ++k) best = std::min(best, SegmentDistance(path[k], path[k + 1], p_N_m));
  return best;
}

}  // namespace hexsim::control
