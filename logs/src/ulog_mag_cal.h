// PX4's magnetometer calibration as a ULog records it (private to logs/). PX4 corrects a raw reading
// as calibrated = R·S·(raw + P·comp − off) (src/lib/sensor_calibration/Magnetometer.cpp, Correct()),
// with, for the calibration slot n whose CAL_MAGn_ID equals the sensor's device id:
//   off = CAL_MAGn_X/Y/ZOFF (gauss), S = [[XSCALE, XODIAG, YODIAG], [XODIAG, YSCALE, ZODIAG],
//   [YODIAG, ZODIAG, ZSCALE]], comp = CAL_MAGn_X/Y/ZCOMP (times the throttle or current P),
//   R = CAL_MAGn_ROT for an external sensor, the board rotation (SENS_BOARD_ROT and the
//   SENS_BOARD_X/Y/Z_OFF trims, degrees) for an internal one (CAL_MAGn_ROT = −1).
#pragma once

#include <nlohmann/json.hpp>

#include "hexsim/logs/ulog.h"

namespace hexsim::logs::internal {

// Where a magnetometer topic stands: how its numbers relate to the raw reading.
enum class MagFrame {
  kRaw,               // sensor_mag from PX4 1.11 on: the raw reading, nothing applied
  kDriverCalibrated,  // sensor_mag before 1.11 (x_raw/scaling fields): S·(raw − off), no R
  kCalibrated,        // vehicle_magnetometer, or sensor_combined magnetometer_ga: R·S·(raw − off)
};

// The meta's `px4_calibration` of one compass: {index, matched_by ("device_id" | "CAL_MAG_PRIME" | "instance"),
// offsets_G, scales, offdiagonals, power_compensation (G per unit P), power_compensation_type
// (CAL_MAG_COMP_TYP), rotation, rotation_known, rotation_matrix (row-major, sensor → body; identity
// for kDriverCalibrated)}. A rotation is known when the log's release fixes its meaning (0..25
// always; 26..47 from PX4 1.12 on; 26..34 in 1.10 and older; 100 custom with CAL_MAGn_ROLL/PITCH/YAW). Null when the log has no CAL_MAGn_*
// parameters for it. device_id ≤ 0: instance 0 (the primary) by CAL_MAG_PRIME when a slot holds that
// id, else matched by `instance`.
nlohmann::json Px4MagCalibration(const ULog& u, double device_id, int instance, MagFrame frame);

}  // namespace hexsim::logs::internal
