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

 private:
  std::vector<std::string> names_;
  std::unordered_map<std::string, size_t> index_;
  std::vector<std::vector<double>> data_;
  size_t rows_ = 0;
};

// "x/log.csv" -> "x/log.meta.json".
std::string MetaPathFor(const std::string& csv_path);

// Serialises the table as CSV (header row, shortest round-trip numbers, empty cell for missing).
std::string FlightLogToCsv(const FlightLog& log);
// Writes `path` and its meta side file, each atomically.
Status WriteFlightLog(const FlightLog& log, const std::string& path);

// Parses CSV text. Errors name `name`, the line and the column.
Result<FlightLog> ParseFlightLogCsv(const std::string& text, const std::string& name);
// Reads a FlightLog CSV and, when present, its meta side file. Requires a `t_s` column.
Result<FlightLog> ReadFlightLog(const std::string& path);

}  // namespace hexsim::logs
