// DIR/results.sqlite, table `runs` (CONTRACTS.md `hexsim batch`): one row per run, written in its
// own transaction (WAL journal), keyed by run_id, so a killed batch loses at most the runs in flight
// and a resumed or merged batch holds every run exactly once.
#pragma once

#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hexsim/batch/batch_spec.h"
#include "hexsim/common/status.h"
#include "hexsim/sim/run_summary.h"

struct sqlite3;

namespace hexsim::batch {

// A summary figure stored as a column: its column name and its JSON pointer in summary.json.
struct MetricColumn {
  const char* column;
  std::optional<double> (*value)(const sim::RunSummary&);  // none: NULL
};
// distance_m, cross_track_max_m, cross_track_rms_m, yaw_error_max_deg, yaw_error_rms_deg, energy_Wh,
// current_max_A, current_mean_A, mission_time_s, flown_s (the summary's duration_s).
const std::vector<MetricColumn>& MetricColumns();

// Run statuses: the summary's completed | not_completed | diverged, and the batch's own
// failed (the run returned an error), crashed (no result: a signal or an exit without one),
// timeout (killed after --run-timeout).
bool IsFailure(const std::string& status);

struct RunRow {
  std::string run_id, params_json;
  std::string mission, vehicle, world, calibration, estimator;
  uint64_t seed = 0;
  std::string status, reason;
  std::map<std::string, std::optional<double>> metrics;  // by MetricColumns() name; nullopt = NULL
  std::string waypoints_json = "[]";
  std::string summary_json;  // summary.json without wall_s (empty when the run left none)
  double wall_s = 0.0;
  std::string host, version, finished_at;
};

// A row from a run's summary.
RunRow RowFromSummary(const RunPoint& point, const sim::RunSummary& summary, double wall_s);
// A row for a run that left no summary (status failed | crashed | timeout).
RunRow FailedRow(const RunPoint& point, const std::string& status, const std::string& reason, double wall_s);

class ResultsDb {
 public:
  ResultsDb() = default;
  ResultsDb(const ResultsDb&) = delete;
  ResultsDb& operator=(const ResultsDb&) = delete;
  ResultsDb(ResultsDb&& o) noexcept : db_(o.db_), path_(std::move(o.path_)) { o.db_ = nullptr; }
  ResultsDb& operator=(ResultsDb&& o) noexcept;
  ~ResultsDb();

  // Opens (create: creating it and the table if missing) a results file.
  static Result<ResultsDb> Open(const std::string& path, bool create);

  // Inserts one row in its own transaction; a row whose run_id is present already is kept as is
  // (*inserted = false).
  Status Insert(const RunRow& row, bool* inserted = nullptr);
  Result<std::set<std::string>> RunIds() const;
  // Every row, ordered by run_id.
  Result<std::vector<RunRow>> ReadAll() const;
  Result<int64_t> Count() const;
  // Copies the rows of another results file whose run_id is not here yet, in one transaction.
  Status MergeFrom(const std::string& other_path, int64_t* added);

  const std::string& path() const { return path_; }

 private:
  Status Exec(const std::string& sql) const;
  sqlite3* db_ = nullptr;
  std::string path_;
};

// ISO 8601 UTC time, e.g. 2025-11-23T09:40:12Z.
std::string NowUtc();
std::string HostName();

}  // namespace hexsim::batch
