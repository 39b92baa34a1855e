// The motor output stage's spool states, as ArduPilot's AP_MotorsMulticopter::output_logic:
//
//   SHUT_DOWN ──► GROUND_IDLE ──► SPOOLING_UP ──► THROTTLE_UNLIMITED
//       ▲             │ ▲                                │
//       └─────────────┘ └──────── SPOOLING_DOWN ◄────────┘
//
// GROUND_IDLE: the motors turn at the ESC's idle (duty_min); spin_up_ratio moves towards 1 (going
// up) or 0 (going down) by dt/spool_up_time. SPOOLING_UP: the collective cap (a fraction of the
// largest collective thrust) rises from 0 by dt/spool_up_time until it reaches the collective the
// controller asks for, which ends the spool-up; roll/pitch/yaw are mixed on top of the capped
// collective, as ArduPilot's throttle_thrust_max. SPOOLING_DOWN: the cap falls by
// dt/spool_up_time to 0. A spool time of 0 makes every transition immediate.
#pragma once

namespace hexsim::control {

enum class SpoolState { kShutDown, kGroundIdle, kSpoolingUp, kThrottleUnlimited, kSpoolingDown };
const char* SpoolStateName(SpoolState state);

class Spool {
 public:
  explicit Spool(double spool_up_time_s);

  // One output-stage tick: `run` = the motors are wanted (THROTTLE_UNLIMITED) or not (SHUT_DOWN);
  // `collective_fraction` is the collective the controller asks for, 0..1 of the largest.
  void Step(bool run, double collective_fraction, double dt_s);

  SpoolState state() const { return state_; }
  // Motors spinning (every state but SHUT_DOWN).
  bool spinning() const { return state_ != SpoolState::kShutDown; }
  // The controller's output reaches the motors (SPOOLING_UP, THROTTLE_UNLIMITED, SPOOLING_DOWN);
  // otherwise they stay at idle (GROUND_IDLE) or off (SHUT_DOWN).
  bool mixing() const { return state_ != SpoolState::kShutDown && state_ != SpoolState::kGroundIdle; }
  // The collective cap, 0..1 of the largest collective thrust (1 when unlimited).
  double collective_cap() const { return cap_; }
  double spin_up_ratio() const { return spin_up_; }

 private:
  double StepFraction(double dt_s) const;
  double spool_up_time_s_;
  SpoolState state_ = SpoolState::kShutDown;
  double spin_up_ = 0.0;
  double cap_ = 0.0;
};

}  // namespace hexsim::control
