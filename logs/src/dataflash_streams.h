// Native-rate streams of a DataFlash log (private to logs/): each sensor message at its own rate with
// its own time stamps, never resampled (CONTRACTS, real data: `<log>.<stream>.csv`).
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "hexsim/logs/dataflash.h"
#include "hexsim/logs/flight_log.h"

namespace hexsim::logs::internal {

// How RCOU PWM becomes motor_i_u: u = clamp((pwm − min)/(max − min), 0, 1) for the first `motors`
// channels (all channels when 0).
struct MotorMapping {
  double pwm_min_us = 1000.0;
  double pwm_max_us = 2000.0;
  size_t motors = 0;
};

// The streams (name, table with t_s first), in a fixed order, only those with samples:
//   imu, imu2, imu3  IMU instances 0..2: gyro_*_radps, accel_*_mps2, imu_temp_C
//   rcou             motor_i_u (the mapping above) and pwm_j_us for every output channel
//   batt             CURR (3.x) or BAT/BATT instance 0: current_A, voltage_V
//   baro             BARO instance 0: baro_alt_m
//   gps              GPS instance 0, 3-D fix: lat_deg, lon_deg, alt_m, gps_vel_N/E/D_mps
//   mag, mag2, mag3  compass instances 0..2: <prefix>_x/y/z_uT as logged
//   ekf              XKF1, else NKF1, else EKF1 (core 0): pos_N/E/D_m, vel_N/E/D_mps
//   ctun             control_u (0..1000)
// A sample whose time is damaged (non-finite, earlier than the last kept one, or later than both of
// its next two) is dropped and counted in `*dropped`.
std::vector<std::pair<std::string, FlightLog>> DataFlashStreams(std::string_view bytes, const MotorMapping& motors,
                                                                 size_t* dropped);

// Instance of a multi-instance message: MAG2 -> 1, or its instance column (I / Inst / C) when
// present; -1 when the name does not belong to `base`.
int InstanceOf(const DataFlashMessage& m, const std::string& base);
// Field value in µT from a decoded MAG field (Gauss when the unit is known, else milligauss counts).
double MagToMicroTesla(const DataFlashMessage& m, const char* field);
// Field index of output channel `channel` (1-based) in an RCOU format: C<i> (3.4+), Ch<i> (3.3) or
// Chan<i> (3.2); -1 when the format has none.
int RcouField(const DataFlashFormat& format, size_t channel);
// Boot time of a GPS message (3.3 logs carry GPS time of week in TimeMS; T is the boot time).
double GpsBootTime_s(const DataFlashMessage& m);

}  // namespace hexsim::logs::internal
