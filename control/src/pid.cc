#include "hexsim/control/pid.h"

#include <algorithm>
#include <cmath>

#include "hexsim/common/rotation.h"

namespace hexsim::control {

double Pid::Update(double setpoint, double measurement, double dt_s, double feedforward) {
  const double error = setpoint - measurement;
  // Derivative on measurement (no kick on setpoint steps), first-order low-pass filtered.
  double d_raw = 0.0;
  if (has_prev_ && dt_s > 0.0) d_raw = -(measurement - prev_measurement_) / dt_s;
  if (has_prev_) {
    if (gains_.d_filter_hz > 0.0 && dt_s > 0.0) {
      const double tau_s = 1.0 / (2.0 * kPi * gains_.d_filter_hz);
      const double alpha = dt_s / (tau_s + dt_s);
      d_filtered_ += alpha * (d_raw - d_filtered_);
    } else {
      d_filtered_ = d_raw;
    }
  }
  prev_measurement_ = measurement;
  has_prev_ = true;

  const double limit = gains_.output_limit;
  const double u_no_i = gains_.kp * error + gains_.kd * d_filtered_ + feedforward;
  // Conditional integration: integrate unless the output is saturated and the error would drive it
  // further into saturation.
  const double u_prev = u_no_i + integrator_;
  const bool high = u_prev >= limit && error > 0.0;
  const bool low = u_prev <= -limit && error < 0.0;
  if (!high && !low && dt_s > 0.0) integrator_ += gains_.ki * error * dt_s;
  integrator_ = std::clamp(integrator_, -gains_.integrator_limit, gains_.integrator_limit);

  const double u = u_no_i + integrator_;
  const double u_clamped = std::clamp(u, -limit, limit);
  saturated_ = u_clamped != u;
  return u_clamped;
}

void Pid::set_integrator(double value) {
  integrator_ = std::clamp(value, -gains_.integrator_limit, gains_.integrator_limit);
}

void Pid::Reset() {
  integrator_ = 0.0;
  prev_measurement_ = 0.0;
  d_filtered_ = 0.0;
  has_prev_ = false;
  saturated_ = false;
}

}  // namespace hexsim::control
