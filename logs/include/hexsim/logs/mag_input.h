// Compass samples for `hexsim calibrate`, from whatever the user has, the format decided by content:
//   plain x,y,z text    CSV, TSV or whitespace columns, with or without a header (a header names the
//                       axes: x, mag_x, mx, magX, x_raw, ...; exactly three columns without one);
//   FlightLog CSV       columns <compass>_x_uT ... (`hexsim import`, `hexsim run`, turntable
//                       samples.csv with plane/control_u/current_A/angle_deg), one sample per new
//                       <compass>_t_s where that column exists (rows hold the latest sample);
//   ArduPilot .bin      through the DataFlash importer;
//   PX4 .ulg            through the ULog importer (sensor_mag instance 0, 1, 2 = mag, mag2, mag3).
// An ArduPilot log (.bin, or a FlightLog imported from one, via its meta side file) holds the field
// with the autopilot's corrections applied, logged = M·(raw + OFS) + MOT (CONTRACTS): the raw field
// is rebuilt as raw = M⁻¹·(logged − MOT) − OFS, with the log's COMPASS_OFS/DIA/ODI and the per-sample
// motor offsets, so that the result is an absolute calibration. A PX4 log's compass becomes the
// reading PX4's CAL_MAGn offsets and scales act on, u = raw + P·comp (its power compensation, which
// PX4 keeps applying; zero when none is in force): calibrated topics (vehicle_magnetometer, old
// sensor_mag and sensor_combined) give u = S⁻¹·Rᵀ·calibrated + off (ulog_mag_cal.h), raw sensor_mag
// gives u = raw + P·comp with P from the import's px4_mag_power column.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "hexsim/common/status.h"
#include "hexsim/logs/flight_log.h"

namespace hexsim::logs {

struct MagInput {
  std::string format;                  // "xyz", "flightlog", "dataflash", "ulog"
  std::string units;                   // "uT" when the format fixes it; "" = unknown (plain x,y,z)
  std::vector<Eigen::Vector3d> field;  // raw readings, corrections undone where known
  // Present (same length as field) only when the input has the column.
  std::vector<double> control_u, current_A, angle_deg;
  std::vector<std::string> plane;
  std::vector<std::string> notes;      // what was read and how (printed by the command)
  // The offset b (raw = … + b) the autopilot's own calibration implies (ArduPilot: b = −OFS), in the
  // field's units; a fit holds a component its samples cannot determine at this value. Else zero.
  Eigen::Vector3d prior_offset = Eigen::Vector3d::Zero();
  // PX4's calibration slot n (CAL_MAGn_*) of this compass, matched by device id; -1 = unknown
  // (the parameters then take the compass's own index).
  int px4_index = -1;
  // A flight log's attitude and timing, for calibrate's attitude-aided fit (magnetics/calibrate.h
  // FlightContext). q_wxyz: the row's attitude (q_w, q_x, q_y, q_z) at each sample, empty without
  // one; t_s: the sample's own time (<compass>_t_s, else t_s), empty without one.
  std::vector<Eigen::Vector4d> q_wxyz;
  std::vector<double> t_s;
  // y = body_from_raw·raw is the body-frame field the autopilot's offsets act on (ArduPilot: its
  // COMPASS_DIA/ODI matrix times COMPASS_SCALE; PX4: its rotation times CAL_MAGn scales);
  // soft_iron_in_force is the matrix its parameters hold (DIA/ODI; PX4 scales). Identity otherwise.
  Eigen::Matrix3d body_from_raw = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d soft_iron_in_force = Eigen::Matrix3d::Identity();
  // The log's place and date (meta `location`, `date_decimal_year`), for the Earth field.
  bool has_place = false;
  double lat_deg = 0.0, lon_deg = 0.0, alt_m = 0.0, decimal_year = 0.0;
  // The log (a binary log's import, or a FlightLog CSV as read), kept so that a caller needing more of the log (the
  // flight windows) does not read it again; null for other text inputs.
  std::shared_ptr<const FlightLog> log;
  int px4_comp_type = -1;                                   // CAL_MAG_COMP_TYP (-1: not a PX4 log)
  Eigen::Vector3d px4_comp_G = Eigen::Vector3d::Zero();     // its CAL_MAGn_X/Y/ZCOMP
};

// The compass's input from a FlightLog already read (its meta undoes the autopilot's corrections as
// above); `log` is not kept in the result.
Result<MagInput> MagInputFromFlightLog(const FlightLog& log, const std::string& name, const std::string& compass);

// compass: "mag", "mag2", "mag3" (the FlightLog prefix). Bad input names FILE[:LINE] and the field.
Result<MagInput> ParseMagInput(const std::string& bytes, const std::string& name, const std::string& compass,
                               const nlohmann::json& meta = nullptr);
// Reads `path` (and, for a FlightLog CSV, its meta side file when present).
Result<MagInput> ReadMagInput(const std::string& path, const std::string& compass);

// 0 for "mag", n − 1 for "magn"; -1 when `compass` is not such a prefix.
int CompassIndex(const std::string& compass);

}  // namespace hexsim::logs
