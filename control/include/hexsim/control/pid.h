// A scalar PID: derivative on measurement through a first-order low-pass filter, output limits,
// integrator limits and conditional-integration anti-windup.
#pragma once

#include <limits>

namespace hexsim::control {

struct PidGains {
  double kp = 0.0;
  double ki = 0.0;
  double kd = 0.0;
  double output_limit = std::numeric_limits<double>::infinity();      // |u| <= limit
  double integrator_limit = std::numeric_limits<double>::infinity();  // |ki·∫e| <= limit (output units)
  double d_filter_hz = 20.0;  // cut-off of the derivative's first-order filter; <= 0: unfiltered
};

class Pid {
 public:
  explicit Pid(const PidGains& gains = {}) : gains_(gains) {}

  // u = kp·e + I + kd·d(−measurement)/dt + feedforward, e = setpoint − measurement, clamped to
  // ±output_limit. The integrator (kept in output units, I = ki·∫e) only integrates while doing so
  // does not push a saturated output further into saturation, and stays within ±integrator_limit.
  double Update(double setpoint, double measurement, double dt_s, double feedforward = 0.0);
  void Reset();

  // Integrator state in output units (ki·∫e dt).
  double integrator() const { return integrator_; }
  // Sets the integrator (output units, clamped to ±integrator_limit): a bumpless hand-over, as
  // ArduPilot's init_z_controller seeds its accel I term from the throttle in use.
  void set_integrator(double value);
  const PidGains& gains() const { return gains_; }
  void set_gains(const PidGains& gains) { gains_ = gains; }
  // True when the last output was clipped to the output limit.
  bool saturated() const { return saturated_; }

 private:
  PidGains gains_;
  double integrator_ = 0.0;
  double prev_measurement_ = 0.0;
  double d_filtered_ = 0.0;
  bool has_prev_ = false;
  bool saturated_ = false;
};

}  // namespace hexsim::control
