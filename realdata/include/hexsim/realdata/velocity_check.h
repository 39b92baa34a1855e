// Does the log's velocity follow the aircraft? (used by identify and the gap dynamics/accel channels)
//
// Over spans of about 1 s of consecutive flight rows, the change of the logged NED velocity is compared
// with the integral of the measured acceleration, R_NB·f_B + g (trapezoid over the rows):
//   e_a = (Δv_a − ∫(R_NB·f_B + g)_a dt) / T       per NED axis a, span length T
// The spread of e_a about its mean (a constant accelerometer bias drops out) is the mismatch; the
// shared plausibility row `velocity_accel_mismatch_mps2` bounds it. Outside it the velocity is not a
// measurement of this aircraft's motion (e.g. an EKF vertical velocity driven by a failing barometer),
// and nothing that the velocity drives (drag, wind) can be fitted from it.
#pragma once

#include <string>
#include <vector>

#include "hexsim/logs/flight_log.h"
#include "hexsim/realdata/windows.h"

namespace hexsim::realdata {

struct VelocityCheck {
  double mismatch_mps2[3] = {0.0, 0.0, 0.0};  // RMS of e_a about its mean, N, E, D
  size_t spans = 0;                           // 1-s spans compared
  bool checked = false;                       // enough spans (>= kMinSpans) and the columns present
  bool ok = true;                             // not checked, or every axis inside the plausible range
  std::string why;                            // when !ok: one sentence with the numbers and the range
};

// The check over the rows of kind kFlight (q_w..q_z, accel_*_mps2, vel_*_mps).
VelocityCheck CheckVelocityAgainstAccel(const logs::FlightLog& log, const std::vector<RowKind>& row_kind);

}  // namespace hexsim::realdata
