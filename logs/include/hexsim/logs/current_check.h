// Is the log's battery current a current? A data-level check made after every import (DataFlash and
// ULog), against what a flying multirotor must draw:
//   flight rows   armed (where the log says) and the mean motor output at least kFlyingMotorOutput
//                 (or, without motor outputs, control_u at least 1000·kFlyingMotorOutput)
//   current       the flight rows' median current_A under kMinFlightCurrentPerMotor_A per motor
//   voltage       the median voltage_V under kMinCellVoltage_V per cell, the cell count from the
//                 parameters (ArduPilot MOT_BAT_VOLT_MAX / MOT_BAT_VOLT_MIN, PX4 BAT1_N_CELLS /
//                 BAT_N_CELLS); under kMinPackVoltageUnknownCells_V where the count is unknown
// Either flags "current sensor unusable: units or no power monitor" (a wrongly scaled field, or a
// log without a power monitor, which logs 0 A), or "current sensor unusable: not checked in flight"
// where the log's throttle shows the motors never carried the vehicle (no flight rows although the
// log has motor outputs or control_u, or a run on the ground, kMinFlightClimb_m): the rule above is
// the only check of the current's scale, and a ground run's current is no flight current (props
// off, a motor draws its no-load current). A log with no throttle at all cannot tell and keeps its
// current unjudged (usable, with a note). Every current-based fit and conversion downstream must
// stay off when unusable, with that reason. The verdict is written into the meta (and its side file):
//   current_usable          bool
//   current_unusable_why    string, empty when usable
//   current_check           {checked, flight_rows, median_current_A, median_voltage_V, motors,
//                            cells, cells_source, rule}
#pragma once

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hexsim/logs/flight_log.h"

namespace hexsim::logs {

// Motor output (0..1) above which the motors lift: ArduCopter spins its motors armed at
// MOT_SPIN_ARMED ≤ 0.2 (3.x THR_MIN ≤ 200 of 1000) and PX4 idles below 0.15, while hover needs
// about 0.3–0.6 on practical vehicles.
inline constexpr double kFlyingMotorOutput = 0.25;
// A lifting motor draws at least this: the smallest multirotors (65 mm 1S "whoops") hover at about
// 1–2 A per motor; 0.5 A per motor at hover is no multirotor that flies.
inline constexpr double kMinFlightCurrentPerMotor_A = 0.5;
// A lithium cell under load stays above ~3.0 V until it is empty; below 2.5 V per cell it is damaged
// or the voltage is not a voltage.
inline constexpr double kMinCellVoltage_V = 2.5;
// Without a cell count: no multirotor battery pack is under 3 V (one cell at its cut-off).
inline constexpr double kMinPackVoltageUnknownCells_V = 3.0;
// Without a motor count: a multirotor has at least three.
inline constexpr int kMinMultirotorMotors = 3;
// A vehicle that flew climbed: over the rows at flight output its logged height (baro_alt_m, else the
// estimator's pos_D_m) spans at least this (5th to 95th percentile; a barometer on the ground with
// the motors running reads within ±0.1 m). Less is a run on the ground, props off or tied down (a
// public ArduCopter 4.7.0-dev log ran its motors at 0.49 for 24 s at 2.6 A, the barometer within
// 0.1 m): its current is no flight current and is not judged.
inline constexpr double kMinFlightClimb_m = 0.5;
// The logged height's span over `rows` (5th to 95th percentile of baro_alt_m, else pos_D_m; the column
// read in `column`), NaN with fewer than 10 finite heights.
double LoggedHeightSpan_m(const FlightLog& log, const std::vector<size_t>& rows, std::string* column);

struct CurrentSensorCheck {
  bool usable = true;
  std::string why;       // empty when usable; else starts "current sensor unusable: "
  bool checked = false;  // the current was compared with the flight rule (flight rows with a current)
  size_t flight_rows = 0;
  double median_current_A = std::numeric_limits<double>::quiet_NaN();
  double median_voltage_V = std::numeric_limits<double>::quiet_NaN();
  int motors = 0;
  int cells = 0;  // 0 = unknown
  std::string cells_source;
  std::string note;  // what was not checked, and why (e.g. no flight rows)
};

// Judges the log's current and voltage from its columns and its meta (`params`, `motor_count`).
CurrentSensorCheck CheckCurrentSensor(const FlightLog& log);
// Writes the check into a meta object (the keys listed above).
void WriteCurrentCheck(const CurrentSensorCheck& check, nlohmann::json* meta);
// The log's verdict: the meta's (written at import) when it has `current_usable`, else computed now
// (a simulated log, or one imported before the check existed).
CurrentSensorCheck CurrentSensorOf(const FlightLog& log);
// One line for a command's output: "current: usable (flight median 14.1 A over 4 motors, 15.5 V)"
// or "current: current sensor unusable: ...".
std::string CurrentCheckLine(const CurrentSensorCheck& check);

}  // namespace hexsim::logs
