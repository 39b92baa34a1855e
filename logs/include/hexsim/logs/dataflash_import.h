// ArduPilot DataFlash (.bin) -> FlightLog (the schema of ARCHITECTURE.md / CONTRACTS.md).
//
// Rows: one per attitude (ATT) sample, t_s = its boot time. Every other channel is sample-and-hold
// (never interpolated): a row holds the latest sample taken at or before the row's time, and
// `<channel>_t_s` gives that sample's time; cells before a channel's first sample are empty.
//
// Column sources:
//   q_w..q_z, yaw_true_deg  ATT Roll/Pitch/Yaw (the autopilot's own attitude, taken as truth)
//   gyro_*, accel_*, imu_temp_C   IMU (first instance)                        imu_t_s
//   mag_*, mag2_*, mag3_*   MAG, MAG2, MAG3 (or MAG instance I=0,1,2), µT    mag_t_s, ...
//                           as logged, i.e. with the autopilot's offsets applied;
//                           mag*_mot_*_uT per-sample motor offsets when any are non-zero
//   current_A, voltage_V    CURR (3.x) or BAT/BATT (first instance)           batt_t_s
//   motor_i_u               RCOU C1..Cn / Ch1..Chn, (pwm - min)/(max - min) clipped to 0..1 with
//                           min/max from MOT_PWM_MIN/MAX when set, else RC3_MIN/MAX, else
//                           1000/2000; n from FRAME_CLASS or the "Frame:" message   rcou_t_s
//   control_u               CTUN ThrOut (0..1000) or ThO (0..1, x1000)         ctun_t_s
//   gps_N_m/E/D, gps_vel_*  GPS (3-D fix only), relative to the first 3-D fix   gps_t_s
//   baro_alt_m              BARO Alt (first instance)                          baro_t_s
//   pos_*, vel_*, est_pos_*, est_vel_*   EKF position/velocity (XKF1, NKF1 or EKF1, core 0):
//                           the autopilot's estimate, used both as "truth" and as estimate  ekf_t_s
//   mode                    MODE ModeNum (or Mode)
//   waypoint_index          CMD CNum (the latest mission command logged)
//
// Native-rate streams (log.Stream(name), written as `<log>.<stream>.csv`): every IMU, RCOU, battery,
// BARO, GPS, compass, EKF and CTUN sample with its own boot time, never resampled; the streams and
// their columns are listed in logs/src/dataflash_streams.h and in the meta's `streams`.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hexsim/common/status.h"
#include "hexsim/logs/dataflash.h"
#include "hexsim/logs/dataflash_plausibility.h"
#include "hexsim/logs/flight_log.h"

namespace hexsim::logs {

struct ImportOptions {
  // Overrides the PWM range of motor outputs when both are > 0.
  double pwm_min_us = 0.0;
  double pwm_max_us = 0.0;
};

// Damaged sample times: a channel's sample later than both of its next two, or earlier than the
// last kept one, is dropped (rows: ATT samples; counted in damage.rows_dropped / samples_dropped).
struct ImportResult {
  FlightLog log;  // log.meta holds the meta JSON (hexsim.log_meta/1)
  DataFlashDamage damage;
  size_t rows_dropped = 0;  // ATT samples dropped for damaged time or non-finite angles
  RecordDamage records;         // records dropped as implausible (dataflash_plausibility.h)
  size_t records_accepted = 0;  // data records the reader accepted (before the plausibility checks)
  // What the import left out and why, one line each (also the meta's "warnings"): a compass that never
  // measured a field (every sample the same vector; meta "compasses_absent") writes no columns.
  std::vector<std::string> warnings;
};

// Imports a DataFlash byte buffer. `name` is used in messages and the meta's source. Bad input
// (empty, no DataFlash messages, no attitude, more than kMaxDamagedRecordShare of the records damaged)
// is a kBadInput Status; lesser damage is skipped and counted (result.damage, result.records).
Result<ImportResult> ImportDataFlash(const std::string& bytes, const std::string& name,
                                     const ImportOptions& options = {});
// Reads `path` and imports it.
Result<ImportResult> ImportDataFlashFile(const std::string& path, const ImportOptions& options = {});
// Writes `csv_path` and its `.meta.json` side file atomically (WriteFlightLog).
Status WriteImport(const ImportResult& result, const std::string& csv_path);

// A human summary for `hexsim import --info`: message types with counts and rates, time span,
// firmware, parameters of interest, damage counts.
std::string DataFlashInfo(const std::string& bytes, const std::string& name);
// The same as JSON (hexsim.dataflash_info/1).
nlohmann::json DataFlashInfoJson(const std::string& bytes, const std::string& name);

// Decimal year (UTC) of a GPS week and time of week.
double DecimalYearFromGps(int week, double time_of_week_s);
// Decimal year (UTC) of a Unix time in seconds, and the same time as ISO 8601 UTC ("2015-11-02T10:04:05Z").
double DecimalYearFromUnix(double unix_s);
std::string IsoUtcFromUnix(double unix_s);
// Whether a parameter is one the meta keeps (COMPASS_*, MOT_PWM_*, RC3_*, BATT_*, FRAME*, ...).
bool IsParameterOfInterest(const std::string& name);

}  // namespace hexsim::logs
