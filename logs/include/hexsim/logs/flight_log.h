// FlightLog: one schema for simulated and real flights (see ARCHITECTURE.md / CONTRACTS.md).
// A column table of doubles; a missing cell is NaN and is written as an empty CSV cell.
#pragma once

#include <cmath>
#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

#include <nlohmann/json.hpp>

#include "hexsim/common/status.h"

namespace hexsim::logs {

inline constexpr double kMissing = std::numeric_limits<double>::quiet_NaN();

class FlightLog {
 public:
  // Adds a column (all rows so far missing) or returns the existing one's index.
  size_t AddColumn(const std::string& name);
  // Index of a column, or -1.
  int ColumnIndex(const std::string& name) const;
  bool Has(const std::string& name) const { return ColumnIndex(name) >= 0; }
  // Appends a row of missing cells.
  void AppendRow();
  // Reserves room for `rows` rows in every column added so far (no reallocation while appending
  // up to that many; columns added later are not affected). Contents and rows() are unchanged.
  void Reserve(size_t rows);
  // Sets a cell of the last row.
  void Set(size_t column, double value) { data_[column].back() = value; }
  void Set(const std::string& name, double value) { Set(AddColumn(name), value); }
  // A whole column; the column must exist.
  const std::vector<double>& Column(const std::string& name) const;
  const std::vector<double>& Column(size_t index) const { return data_[index]; }
  std::vector<double>& MutableColumn(size_t index) { return data_[index]; }
  double At(size_t row, size_t column) const { return data_[column][row]; }

  size_t rows() const { return rows_; }
  const std::vector<std::string>& columns() const { return names_; }

  // The side file's content (`<log>.meta.json`).
  nlohmann::json meta = nlohmann::json::object();

  // Multi-rate streams (CONTRACTS, real data): a stream is a table of its own with its own
  // `t_s`, one row per sample of that sensor at its native rate, never resampled ("imu", "rcou",
  // "batt", ...). Written beside the single table as `<log>.<stream>.csv` and listed in the meta's
  // `streams`. nullptr when the log has no such stream.
  const FlightLog* Stream(const std::string& name) const;
  // Adds or replaces a stream (the stream's own streams are dropped).
  void SetStream(const std::string& name, FlightLog stream);
  const std::vector<std::string>& stream_names() const { return stream_names_; }

 private:
  std::vector<std::string> names_;
  std::unordered_map<std::string, size_t> index_;
  std::vector<std::vector<double>> data_;
  size_t rows_ = 0;
  std::vector<std::string> stream_names_;
  std::vector<FlightLog> streams_;  // parallel to stream_names_
};

// "x/log.csv" -> "x/log.meta.json".
std::string MetaPathFor(const std::string& csv_path);
// A stream name is 1-32 of [a-z0-9_] (it becomes part of a file name).
bool IsStreamName(const std::string& name);
// "x/log.csv", "imu" -> "x/log.imu.csv".
std::string StreamPathFor(const std::string& csv_path, const std::string& stream);

// Serialises the table as CSV (header row, shortest round-trip numbers, empty cell for missing).
std::string FlightLogToCsv(const FlightLog& log);
// Writes `path`, its streams (`<log>.<stream>.csv`) and its meta side file, each atomically; the
// meta gains `streams: {name: {file, rows, rate_hz, columns}}` when there are streams.
Status WriteFlightLog(const FlightLog& log, const std::string& path);

// A stream at its own rate, for consumers that work on native rates: the log's stream when it has
// one; otherwise the distinct samples the single table holds (the rows where `<stream>_t_s`
// changes, timed by it; every row when the table has no such column), with the stream's columns
// the table has. Known streams: imu (gyro_*, accel_*, imu_temp_C; imu_t_s), rcou (motor_i_u;
// rcou_t_s), batt (current_A, voltage_V; batt_t_s), baro, gps, mag/mag2/mag3, ekf (pos_*, vel_*;
// ekf_t_s), ctun (control_u). Zero rows when neither has it. `from_table` (optional) tells which.
FlightLog StreamAtOwnRate(const FlightLog& log, const std::string& stream, bool* from_table = nullptr);

// Parses CSV text. Errors name `name`, the line and the column.
Result<FlightLog> ParseFlightLogCsv(const std::string& text, const std::string& name);
// Reads a FlightLog CSV and, when present, its meta side file and the streams the meta lists
// (a listed stream whose file is absent is left out; one that does not parse is bad input).
// Requires a `t_s` column.
Result<FlightLog> ReadFlightLog(const std::string& path);
// Reads one stream file beside `csv_path` (bad input when absent).
Result<FlightLog> ReadStream(const std::string& csv_path, const std::string& stream);

}  // namespace hexsim::logs
