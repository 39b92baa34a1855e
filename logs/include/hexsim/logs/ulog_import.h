// PX4 ULog (.ulg) -> FlightLog (CONTRACTS schema), the counterpart of dataflash_import.h.
//
// Rows: one per vehicle_attitude sample (instance 0), t_s = its timestamp (s since boot). Every
// other channel is sample-and-hold with its `<channel>_t_s`, never interpolated:
//   q_w..q_z, roll/pitch/yaw_deg   vehicle_attitude q (Hamilton, FRD body → NED)
//   gyro_*_radps, accel_*_mps2     sensor_combined gyro_rad, accelerometer_m_s2      imu_t_s
//   mag_*, mag2_*, mag3_* (µT)     sensor_mag instances 0, 1, 2 (x, y, z in gauss, uncalibrated);
//                                  without sensor_mag: vehicle_magnetometer (already calibrated:
//                                  warned), or the magnetometer_ga of old sensor_combined  mag_t_s ...
//   current_A, voltage_V           battery_status current_a, voltage_v               batt_t_s
//   motor_i_u                      actuator_motors control[i] (0..1), else actuator_outputs
//                                  output[i] as (pwm − PWM_MAIN_MIN)/(MAX − MIN), 1000/2000 by default;
//                                  n from CA_ROTOR_COUNT, else 4                      rcou_t_s
//   control_u                      vehicle_thrust_setpoint −xyz[2] ×1000, else actuator_controls_0
//                                  control[3] ×1000                                     ctun_t_s
//   pos_*/vel_*, est_pos_*/est_vel_*   vehicle_local_position x, y, z, vx, vy, vz       ekf_t_s
// Multi-rate streams (<log>.<stream>.csv) are not written for ULog yet: the single table only.
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
