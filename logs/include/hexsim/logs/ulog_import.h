// PX4 ULog (.ulg) -> FlightLog (CONTRACTS schema), the counterpart of dataflash_import.h.
//
// Rows: one per vehicle_attitude sample (instance 0), t_s = its timestamp (s since boot). Every
// other channel is sample-and-hold with its `<stream>_t_s`, never interpolated, and is also written
// at its native rate as the stream `<stream>` (`<log>.<stream>.csv`, one row per logged sample;
// samples whose time is damaged or runs backwards are dropped and counted in the meta's
// `stream_samples_dropped`):
//   att      q_w..q_z, roll/pitch/yaw_deg   vehicle_attitude q (Hamilton, FRD body → NED)
//   imu      gyro_*_radps, accel_*_mps2     sensor_combined gyro_rad, accelerometer_m_s2
//   mag, mag2, mag3  <prefix>_x/y/z_uT      sensor_mag instances 0, 1, 2 (gauss ×100); without
//            sensor_mag: vehicle_magnetometer instances, else the magnetometer_ga of old
//            sensor_combined. The meta's `compasses` says each one's `frame`: raw (sensor_mag from
//            PX4 1.11 on), driver-calibrated (older sensor_mag) or calibrated, and its
//            `px4_calibration` (the CAL_MAGn slot matched by device id, see ulog_mag_cal.h);
//            calibrated topics are warned about.
//   batt     current_A, voltage_V           battery_status current_a, voltage_v
//   rcou     motor_i_u                      actuator_motors control[i] (0..1), else actuator_outputs
//            output[i] as (pwm − PWM_MAIN_MIN)/(MAX − MIN), 1000/2000 by default (the stream also
//            holds pwm_i_us); n from CA_ROTOR_COUNT, else 4
//   ctun     control_u                      vehicle_thrust_setpoint −xyz[2] ×1000, else
//            actuator_controls_0 control[3] ×1000
//   ekf      pos_*/vel_*, est_pos_*/est_vel_*   vehicle_local_position x, y, z, vx, vy, vz
//   baro     baro_alt_m                     vehicle_air_data baro_alt_meter
//   gps      gps_vel_N/E/D_mps (stream also lat_deg, lon_deg, alt_m)   vehicle_gps_position, 3-D fixes
// Table columns without a stream:
//   armed          0/1: actuator_armed.armed, else vehicle_status arming_state == 2 (ARMED); before
//                  the first record, the first record's state (the meta's `armed_source` says which)
//   px4_mag_power  PX4's magnetometer power-compensation signal P, only when CAL_MAG_COMP_TYP is 1..3
//                  and a compass has nonzero CAL_MAGn_X/Y/ZCOMP: 1 throttle while armed
//                  (actuator_controls_0 control[3], else |vehicle_thrust_setpoint xyz|), 2/3 the current
//                  of battery_status instance 0/1 in kA (meta `px4_mag_power_compensation`)
#pragma once

#include <string>
#include <vector>

#include "hexsim/common/status.h"
#include "hexsim/logs/flight_log.h"

namespace hexsim::logs {

struct ULogImport {
  FlightLog log;                      // log.meta: hexsim.log_meta/1, format "px4-ulog"
  std::vector<std::string> warnings;  // e.g. the magnetometer topic is already calibrated
};

// Bad input (kBadInput naming `name`): not a ULog, or no vehicle_attitude samples.
Result<ULogImport> ImportULog(const std::string& bytes, const std::string& name);

}  // namespace hexsim::logs
