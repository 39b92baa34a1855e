#include "hexsim/batch/results_db.h"

#include <sqlite3.h>
#include <unistd.h>

#include <cmath>
#include <ctime>

#include <fmt/format.h>

#include "hexsim/common/paths.h"

namespace hexsim::batch {

using nlohmann::json;

namespace {

constexpr int kBusyTimeout_ms = 10000;

// A prepared statement, finalised on scope exit.
class Stmt {
 public:
  Stmt(sqlite3* db, const std::string& sql) { rc_ = sqlite3_prepare_v2(db, sql.c_str(), -1, &s_, nullptr); }
  ~Stmt() { sqlite3_finalize(s_); }
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;
  bool ok() const { return rc_ == SQLITE_OK; }
  sqlite3_stmt* get() const { return s_; }

 private:
  sqlite3_stmt* s_ = nullptr;
  int rc_ = SQLITE_OK;
};

std::string Text(sqlite3_stmt* s, int col) {
  const unsigned char* t = sqlite3_column_text(s, col);
  return t ? reinterpret_cast<const char*>(t) : "";
}

std::string CreateTableSql() {
  std::string sql =
      "CREATE TABLE IF NOT EXISTS runs (run_id TEXT PRIMARY KEY NOT NULL, params_json TEXT NOT NULL, mission TEXT, "
      "vehicle TEXT, world TEXT, calibration TEXT, estimator TEXT, seed INTEGER, status TEXT NOT NULL, reason TEXT";
  for (const auto& m : MetricColumns()) sql += fmt::format(", {} REAL", m.column);
  sql += ", waypoints_json TEXT, summary_json TEXT, wall_s REAL, host TEXT, version TEXT, finished_at TEXT)";
  return sql;
}

// Column names in table order.
std::vector<std::string> Columns() {
  std::vector<std::string> c = {"run_id", "params_json", "mission", "vehicle", "world", "calibration",
                                "estimator", "seed", "status", "reason"};
  for (const auto& m : MetricColumns()) c.emplace_back(m.column);
  for (const char* n : {"waypoints_json", "summary_json", "wall_s", "host", "version", "finished_at"}) c.emplace_back(n);
  return c;
}

std::string ColumnList() {
  std::string s;
  for (const auto& c : Columns()) s += (s.empty() ? "" : ", ") + c;
  return s;
}

RunRow BaseRow(const RunPoint& p, double wall_s) {
  RunRow r;
  r.run_id = p.RunId();
  r.params_json = p.CanonicalJson();
  r.mission = p.mission;
  r.vehicle = p.vehicle;
  r.world = p.world;
  r.calibration = p.calibration;
  r.estimator = p.estimator;
  r.seed = p.seed;
  for (const auto& m : MetricColumns()) r.metrics[m.column] = std::nullopt;
  r.wall_s = wall_s;
  r.host = HostName();
  r.version = Version();
  r.finished_at = NowUtc();
  return r;
}

}  // namespace

const std::vector<MetricColumn>& MetricColumns() {
  using S = sim::RunSummary;
  static const std::vector<MetricColumn> kColumns = {
      {"distance_m", [](const S& s) -> std::optional<double> { return s.distance_m; }},
      {"cross_track_max_m", [](const S& s) -> std::optional<double> { return s.cross_track_m.max; }},
      {"cross_track_rms_m", [](const S& s) -> std::optional<double> { return s.cross_track_m.rms; }},
      {"yaw_error_max_deg", [](const S& s) -> std::optional<double> { return s.yaw_error_deg.max; }},
      {"yaw_error_rms_deg", [](const S& s) -> std::optional<double> { return s.yaw_error_deg.rms; }},
      {"energy_Wh", [](const S& s) -> std::optional<double> { return s.energy_Wh; }},
      {"current_max_A", [](const S& s) -> std::optional<double> { return s.current_max_A; }},
      {"current_mean_A", [](const S& s) -> std::optional<double> { return s.current_mean_A; }},
      {"mission_time_s", [](const S& s) { return s.mission_time_s; }},
      {"flown_s", [](const S& s) -> std::optional<double> { return s.duration_s; }},
  };
  return kColumns;
}

bool IsFailure(const std::string& status) { return status != "completed" && status != "not_completed"; }

RunRow RowFromSummary(const RunPoint& point, const sim::RunSummary& summary, double wall_s) {
  RunRow r = BaseRow(point, wall_s);
  r.status = sim::RunStatusName(summary.status);
  r.reason = summary.reason;
  r.mission = summary.mission;
  r.vehicle = summary.vehicle;
  r.world = summary.world;
  r.calibration = summary.calibration;
  r.estimator = summary.estimator;
  for (const auto& m : MetricColumns()) {
    const std::optional<double> v = m.value(summary);
    if (v && std::isfinite(*v)) r.metrics[m.column] = *v;
  }
  json stored = sim::ToJson(summary);
  r.waypoints_json = stored["waypoints"].dump();
  stored.erase("wall_s");
  r.summary_json = stored.dump();
  r.version = summary.version;
  return r;
}

RunRow FailedRow(const RunPoint& point, const std::string& status, const std::string& reason, double wall_s) {
  RunRow r = BaseRow(point, wall_s);
  r.status = status;
  r.reason = reason;
  return r;
}

ResultsDb& ResultsDb::operator=(ResultsDb&& o) noexcept {
  if (this != &o) {
    if (db_) sqlite3_close(db_);
    db_ = o.db_;
    path_ = std::move(o.path_);
    o.db_ = nullptr;
  }
  return *this;
}

ResultsDb::~ResultsDb() {
  if (db_) sqlite3_close(db_);
}

Status ResultsDb::Exec(const std::string& sql) const {
  char* err = nullptr;
  if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
    Status s = Status::BadInput(fmt::format("{}: sqlite: {}", path_, err ? err : "error"));
    sqlite3_free(err);
    return s;
  }
  return Status::Ok();
}

Result<ResultsDb> ResultsDb::Open(const std::string& path, bool create) {
  ResultsDb db;
  db.path_ = path;
  const int flags = SQLITE_OPEN_READWRITE | (create ? SQLITE_OPEN_CREATE : 0);
  if (sqlite3_open_v2(path.c_str(), &db.db_, flags, nullptr) != SQLITE_OK) {
    return Status::BadInput(fmt::format("{}: cannot open results file: {}", path,
                                        db.db_ ? sqlite3_errmsg(db.db_) : "out of memory"));
  }
  sqlite3_busy_timeout(db.db_, kBusyTimeout_ms);
  // WAL: a committed row survives a killed process; synchronous=FULL: and a power cut.
  HEXSIM_RETURN_IF_ERROR(db.Exec("PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL;"));
  if (create) {
    HEXSIM_RETURN_IF_ERROR(db.Exec(CreateTableSql()));
  } else {
    Stmt s(db.db_, "SELECT count(*) FROM sqlite_master WHERE type='table' AND name='runs'");
    if (!s.ok() || sqlite3_step(s.get()) != SQLITE_ROW || sqlite3_column_int(s.get(), 0) != 1) {
      return Status::BadInput(path + ": not a hexsim results file (no table 'runs')");
    }
  }
  return db;
}

Status ResultsDb::Insert(const RunRow& row, bool* inserted) {
  const auto cols = Columns();
  std::string q;
  for (size_t i = 0; i < cols.size(); ++i) q += i ? ", ?" : "?";
  Stmt s(db_, fmt::format("INSERT OR IGNORE INTO runs ({}) VALUES ({})", ColumnList(), q));
  if (!s.ok()) return Status::BadInput(fmt::format("{}: sqlite: {}", path_, sqlite3_errmsg(db_)));
  int i = 1;
  auto text = [&](const std::string& v) { sqlite3_bind_text(s.get(), i++, v.c_str(), -1, SQLITE_TRANSIENT); };
  text(row.run_id);
  text(row.params_json);
  text(row.mission);
  text(row.vehicle);
  text(row.world);
  text(row.calibration);
  text(row.estimator);
  sqlite3_bind_int64(s.get(), i++, static_cast<sqlite3_int64>(row.seed));
  text(row.status);
  text(row.reason);
  for (const auto& m : MetricColumns()) {
    const auto it = row.metrics.find(m.column);
    if (it != row.metrics.end() && it->second) {
      sqlite3_bind_double(s.get(), i++, *it->second);
    } else {
      sqlite3_bind_null(s.get(), i++);
    }
  }
  text(row.waypoints_json);
  text(row.summary_json);
  sqlite3_bind_double(s.get(), i++, row.wall_s);
  text(row.host);
  text(row.version);
  text(row.finished_at);
  // Autocommit: the statement is its own transaction.
  if (sqlite3_step(s.get()) != SQLITE_DONE) return Status::BadInput(fmt::format("{}: sqlite: {}", path_, sqlite3_errmsg(db_)));
  if (inserted) *inserted = sqlite3_changes(db_) > 0;
  return Status::Ok();
}

Result<std::set<std::string>> ResultsDb::RunIds() const {
  Stmt s(db_, "SELECT run_id FROM runs");
  if (!s.ok()) return Status::BadInput(fmt::format("{}: sqlite: {}", path_, sqlite3_errmsg(db_)));
  std::set<std::string> ids;
  while (sqlite3_step(s.get()) == SQLITE_ROW) ids.insert(Text(s.get(), 0));
  return ids;
}

Result<int64_t> ResultsDb::Count() const {
  Stmt s(db_, "SELECT count(*) FROM runs");
  if (!s.ok() || sqlite3_step(s.get()) != SQLITE_ROW) return Status::BadInput(path_ + ": sqlite: cannot count runs");
  return static_cast<int64_t>(sqlite3_column_int64(s.get(), 0));
}

Result<std::vector<RunRow>> ResultsDb::ReadAll() const {
  Stmt s(db_, fmt::format("SELECT {} FROM runs ORDER BY run_id", ColumnList()));
  if (!s.ok()) return Status::BadInput(fmt::format("{}: sqlite: {}", path_, sqlite3_errmsg(db_)));
  std::vector<RunRow> rows;
  while (sqlite3_step(s.get()) == SQLITE_ROW) {
    RunRow r;
    int i = 0;
    r.run_id = Text(s.get(), i++);
    r.params_json = Text(s.get(), i++);
    r.mission = Text(s.get(), i++);
    r.vehicle = Text(s.get(), i++);
    r.world = Text(s.get(), i++);
    r.calibration = Text(s.get(), i++);
    r.estimator = Text(s.get(), i++);
    r.seed = static_cast<uint64_t>(sqlite3_column_int64(s.get(), i++));
    r.status = Text(s.get(), i++);
    r.reason = Text(s.get(), i++);
    for (const auto& m : MetricColumns()) {
      if (sqlite3_column_type(s.get(), i) == SQLITE_NULL) {
        r.metrics[m.column] = std::nullopt;
      } else {
        r.metrics[m.column] = sqlite3_column_double(s.get(), i);
      }
      ++i;
    }
    r.waypoints_json = Text(s.get(), i++);
    r.summary_json = Text(s.get(), i++);
    r.wall_s = sqlite3_column_double(s.get(), i++);
    r.host = Text(s.get(), i++);
    r.version = Text(s.get(), i++);
    r.finished_at = Text(s.get(), i++);
    rows.push_back(std::move(r));
  }
  return rows;
}

Status ResultsDb::MergeFrom(const std::string& other_path, int64_t* added) {
  {
    auto other = Open(other_path, /*create=*/false);  // checks it is a results file
    if (!other.ok()) return other.status();
  }
  auto before = Count();
  if (!before.ok()) return before.status();
  char* quoted = sqlite3_mprintf("%Q", other_path.c_str());
  const std::string attach = fmt::format("ATTACH DATABASE {} AS shard", quoted);
  sqlite3_free(quoted);
  HEXSIM_RETURN_IF_ERROR(Exec(attach));
  const Status s = Exec(fmt::format("BEGIN IMMEDIATE; INSERT OR IGNORE INTO runs ({0}) SELECT {0} FROM shard.runs; COMMIT;",
                                    ColumnList()));
  if (!s.ok()) (void)Exec("ROLLBACK");
  (void)Exec("DETACH DATABASE shard");
  HEXSIM_RETURN_IF_ERROR(s);
  auto after = Count();
  if (!after.ok()) return after.status();
  if (added) *added = *after - *before;
  return Status::Ok();
}

std::string NowUtc() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

std::string HostName() {
  char buf[256] = {};
  if (gethostname(buf, sizeof buf - 1) != 0) return "unknown";
  return buf;
}

}  // namespace hexsim::batch
