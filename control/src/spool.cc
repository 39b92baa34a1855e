#include "hexsim/control/spool.h"

#include <algorithm>

#include "hexsim/common/status.h"

namespace hexsim::control {

const char* SpoolStateName(SpoolState state) {
  switch (state) {
    case SpoolState::kShutDown: return "shut_down";
    case SpoolState::kGroundIdle: return "ground_idle";
    case SpoolState::kSpoolingUp: return "spooling_up";
    case SpoolState::kThrottleUnlimited: return "throttle_unlimited";
    case SpoolState::kSpoolingDown: return "spooling_down";
  }
  return "?";
}

Spool::Spool(double spool_up_time_s) : spool_up_time_s_(spool_up_time_s) { HEXSIM_CHECK(spool_up_time_s >= 0.0); }

double Spool::StepFraction(double dt_s) const { return spool_up_time_s_ > 0.0 ? dt_s / spool_up_time_s_ : 1.0; }

void Spool::Step(bool run, double collective_fraction, double dt_s) {
  const double step = StepFraction(dt_s);
  switch (state_) {
    case SpoolState::kShutDown:
      spin_up_ = 0.0;
      cap_ = 0.0;
      if (run) state_ = SpoolState::kGroundIdle;
      break;
    case SpoolState::kGroundIdle:
      cap_ = 0.0;
      if (run) {
        spin_up_ = std::min(1.0, spin_up_ + step);
        if (spin_up_ >= 1.0) state_ = SpoolState::kSpoolingUp;
      } else {
        spin_up_ = std::max(0.0, spin_up_ - step);
        if (spin_up_ <= 0.0) state_ = SpoolState::kShutDown;
      }
      break;
    case SpoolState::kSpoolingUp:
      if (!run) {
        state_ = SpoolState::kSpoolingDown;
        break;
      }
      cap_ = std::min(1.0, cap_ + step);
      if (cap_ >= std::clamp(collective_fraction, 0.0, 1.0)) {
        cap_ = 1.0;
        state_ = SpoolState::kThrottleUnlimited;
      }
      break;
    case SpoolState::kThrottleUnlimited:
      cap_ = 1.0;
      if (!run) {
        // The cap starts falling from the collective in use (ArduPilot: from the throttle).
        cap_ = std::clamp(collective_fraction, 0.0, 1.0);
        state_ = SpoolState::kSpoolingDown;
      }
      break;
    case SpoolState::kSpoolingDown:
      if (run) {
        state_ = SpoolState::kSpoolingUp;
        break;
      }
      cap_ = std::max(0.0, cap_ - step);
      if (cap_ <= 0.0) {
        spin_up_ = 1.0;
        state_ = SpoolState::kGroundIdle;
      }
      break;
  }
}

}  // namespace hexsim::control
