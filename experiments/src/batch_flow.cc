#include "hexsim/experiments/batch_flow.h"

#include <unistd.h>

#include <filesystem>
#include <set>

#include <fmt/format.h>

#include "hexsim/batch/pool.h"
#include "hexsim/batch/results_db.h"
#include "hexsim/batch/setup_cache.h"
#include "hexsim/common/atomic_file.h"
#include "hexsim/experiments/ground_calibration.h"
#include "hexsim/experiments/point_runner.h"

namespace hexsim::experiments {

namespace {

namespace fs = std::filesystem;

// Everything that can be checked before a run starts: each point's files and overrides load (into
// `cache`, which the forked workers inherit), and each calibration attaches once.
Status ValidatePoints(const std::string& batch_file, const std::vector<batch::RunPoint>& points,
                      batch::SetupCache* cache) {
  std::set<std::string> keys_seen, calibrations_seen;
  for (const auto& p : points) {
    const bool new_setup = keys_seen.insert(batch::SetupCache::Key(p)).second;
    const bool new_calibration = calibrations_seen.insert(p.calibration).second;
    if (!new_setup && !new_calibration) continue;
    auto setup = cache->Get(p);
    if (!setup.ok()) {
      return Status::BadInput(fmt::format("{}: run {} {}: {}", batch_file, p.RunId(), p.CanonicalJson(),
                                          setup.status().message()));
    }
    if (new_calibration) {
      const Status s = AttachCalibration(p.calibration, &*setup);
      if (!s.ok()) return Status::BadInput(fmt::format("{}: calibrations: {}", batch_file, s.message()));
    }
  }
  return Status::Ok();
}

// The worker's job (in its own process): one mission, its summary; the log too with keep_log.
Result<nlohmann::json> RunOne(const batch::RunPoint& p, batch::SetupCache* cache, const std::string& run_dir,
                              bool keep_log) {
  auto out = FlyPoint(p, cache);
  if (!out.ok()) return out.status();
  if (keep_log) HEXSIM_RETURN_IF_ERROR(WriteRunLog(*out, run_dir));
  return sim::ToJson(out->summary);
}

}  // namespace

Result<BatchOutcome> RunBatch(const std::string& batch_file, const std::vector<batch::RunPoint>& points,
                              const BatchFlowOptions& options, const std::function<void(const BatchPlan&)>& on_plan) {
  batch::SetupCache cache;
  HEXSIM_RETURN_IF_ERROR(ValidatePoints(batch_file, points, &cache));
  BatchOutcome outcome;
  outcome.db_path = options.out + "/" + kResultsFile;
  std::error_code ec;
  if (fs::exists(outcome.db_path, ec) && !options.resume) {
    return Status::BadInput(outcome.db_path +
                            ": exists already; pass --resume to finish that batch, or choose another --out");
  }
  OutputDirectory out;
  HEXSIM_RETURN_IF_ERROR(out.Open(options.out));
  auto db = batch::ResultsDb::Open(outcome.db_path, /*create=*/true);
  if (!db.ok()) return db.status();
  out.Commit();  // from here on, every finished run is a result worth keeping
  auto done = db->RunIds();
  if (!done.ok()) return done.status();
  std::vector<batch::RunPoint> todo;
  for (const auto& p : points) {
    if (!done->count(p.RunId())) todo.push_back(p);
  }
  batch::PoolOptions opt;
  opt.jobs = options.jobs;
  opt.out_dir = options.out;
  opt.run_timeout_s = options.run_timeout_s;
  opt.progress_tty = options.progress_tty;
  opt.already_done = points.size() - todo.size();
  opt.stop = options.stop;
  on_plan(BatchPlan{outcome.db_path, opt.already_done, todo.size()});
  const bool keep = options.keep_logs;
  const std::string runs_dir = options.out + "/runs/";
  auto stats = batch::RunPool(
      todo, [&cache, &runs_dir, keep](const batch::RunPoint& p) { return RunOne(p, &cache, runs_dir + p.RunId(), keep); },
      opt, &*db);
  if (!stats.ok()) return stats.status();
  outcome.finished = stats->finished;
  outcome.wall_s = stats->wall_s;
  outcome.interrupted = stats->interrupted;
  outcome.not_run = stats->not_run;
  // Failed runs of this shard count, including those recorded by an earlier attempt.
  auto rows = db->ReadAll();
  if (!rows.ok()) return rows.status();
  std::set<std::string> mine;
  for (const auto& p : points) mine.insert(p.RunId());
  for (const auto& r : *rows) {
    if (!mine.count(r.run_id)) continue;
    ++outcome.recorded;
    if (batch::IsFailure(r.status)) ++outcome.failed;
  }
  return outcome;
}

Result<MergeOutcome> MergeShards(const std::string& out_dir, const std::vector<std::string>& shards,
                                 const std::function<void(const std::string&, long long)>& on_shard) {
  std::vector<std::string> files;
  for (const auto& s : shards) {
    const std::string f = fs::is_directory(s) ? s + "/" + kResultsFile : s;
    std::error_code ec;
    if (!fs::is_regular_file(f, ec)) return Status::BadInput(f + ": no such results file");
    auto check = batch::ResultsDb::Open(f, /*create=*/false);
    if (!check.ok()) return check.status();
    files.push_back(f);
  }
  OutputDirectory out;
  HEXSIM_RETURN_IF_ERROR(out.Open(out_dir));
  MergeOutcome outcome;
  outcome.path = out.File(kResultsFile);
  outcome.shards = files.size();
  // Built under a temporary name and renamed, so a killed merge never looks finished.
  const std::string tmp = outcome.path + ".tmp." + std::to_string(getpid());
  {
    auto db = batch::ResultsDb::Open(tmp, /*create=*/true);
    if (!db.ok()) return db.status();
    std::error_code ec;
    if (fs::is_regular_file(outcome.path, ec)) {  // merging into an existing result: keep its rows
      int64_t added = 0;
      HEXSIM_RETURN_IF_ERROR(db->MergeFrom(outcome.path, &added));
    }
    for (const auto& f : files) {
      int64_t added = 0;
      HEXSIM_RETURN_IF_ERROR(db->MergeFrom(f, &added));
      auto n = batch::ResultsDb::Open(f, false)->Count();
      outcome.rows_in += n.ok() ? *n : 0;
      on_shard(f, static_cast<long long>(added));
    }
    auto count = db->Count();
    if (!count.ok()) return count.status();
    outcome.distinct_runs = static_cast<long long>(*count);
  }  // closed: the WAL is checkpointed into the file
  std::error_code ec;
  fs::rename(tmp, outcome.path, ec);
  if (ec) return Status::BadInput(outcome.path + ": cannot rename: " + ec.message());
  out.Commit();
  return outcome;
}

}  // namespace hexsim::experiments
