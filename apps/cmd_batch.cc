// hexsim batch BATCH.yaml [--jobs N] [--shard i/N] [--resume] [--run-timeout S] [--keep-logs] [--list] --out DIR
// hexsim batch-report DIR [--json FILE] [--no-plots]   (table on stdout, report.json, report.png, report.html)
// hexsim batch-merge OUT SHARD_DIR...
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "cli_util.h"
#include "commands.h"
#include "hexsim/batch/batch_spec.h"
#include "hexsim/batch/pool.h"
#include "hexsim/batch/report.h"
#include "hexsim/batch/results_db.h"
#include "hexsim/batch/setup_cache.h"
#include "hexsim/common/atomic_file.h"
#include "hexsim/common/paths.h"
#include "hexsim/experiments/ground_calibration.h"
#include "hexsim/experiments/point_runner.h"
#include "hexsim/reports/batch_report.h"
#include "hexsim/reports/headline.h"

namespace hexsim::app {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kResultsFile = "results.sqlite";

struct BatchArgs {
  std::string batch_file;
  int jobs = 0;  // 0: every core
  std::string shard = "0/1";
  bool resume = false;
  bool keep_logs = false;
  bool list = false;
  double run_timeout_s = 0.0;
  std::string out;
};

// Everything that can be checked before a run starts, so bad input fails the batch up front
// (exit 2, nothing written) rather than run by run: each point's files and overrides load (into
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
      const Status s = experiments::AttachCalibration(p.calibration, &*setup);
      if (!s.ok()) return Status::BadInput(fmt::format("{}: calibrations: {}", batch_file, s.message()));
    }
  }
  return Status::Ok();
}

// The worker's job (in its own process): one mission, its summary; the log too with --keep-logs.
Result<json> RunOne(const batch::RunPoint& p, batch::SetupCache* cache, const std::string& run_dir, bool keep_log) {
  auto out = experiments::FlyPoint(p, cache);
  if (!out.ok()) return out.status();
  if (keep_log) HEXSIM_RETURN_IF_ERROR(experiments::WriteRunLog(*out, run_dir));
  return sim::ToJson(out->summary);
}

Status BatchCommand(const BatchArgs& args, int* exit_code) {
  auto spec = batch::LoadBatchFile(args.batch_file);
  if (!spec.ok()) return spec.status();
  auto shard = batch::ParseShard(args.shard);
  if (!shard.ok()) return shard.status();
  const std::vector<batch::RunPoint> all = batch::ExpandBatch(*spec);
  const std::vector<batch::RunPoint> mine = batch::SelectShard(all, *shard);
  if (args.list) {
    for (const auto& p : mine) std::printf("%s %s\n", p.RunId().c_str(), p.CanonicalJson().c_str());
    *exit_code = 0;
    return Status::Ok();
  }
  if (args.out.empty()) return Status::BadInput("batch: --out DIR is required");
  batch::SetupCache cache;
  HEXSIM_RETURN_IF_ERROR(ValidatePoints(spec->file, mine, &cache));
  const int jobs = args.jobs > 0 ? args.jobs : std::max(1, static_cast<int>(sysconf(_SC_NPROCESSORS_ONLN)));
  const std::string db_path = args.out + "/" + kResultsFile;
  std::error_code ec;
  if (fs::exists(db_path, ec) && !args.resume) {
    return Status::BadInput(db_path + ": exists already; pass --resume to finish that batch, or choose another --out");
  }
  OutputDirectory out;
  HEXSIM_RETURN_IF_ERROR(out.Open(args.out));
  auto db = batch::ResultsDb::Open(db_path, /*create=*/true);
  if (!db.ok()) return db.status();
  out.Commit();  // from here on, every finished run is a result worth keeping
  auto done = db->RunIds();
  if (!done.ok()) return done.status();
  std::vector<batch::RunPoint> todo;
  for (const auto& p : mine) {
    if (!done->count(p.RunId())) todo.push_back(p);
  }
  batch::PoolOptions opt;
  opt.jobs = jobs;
  opt.out_dir = args.out;
  opt.run_timeout_s = args.run_timeout_s;
  opt.progress_tty = isatty(STDERR_FILENO) == 1;
  opt.already_done = mine.size() - todo.size();
  std::fprintf(stderr, "hexsim batch: %s: %zu runs (shard %d/%d of %zu), %zu finished before, %zu to run on %d jobs\n",
               spec->name.c_str(), mine.size(), shard->index, shard->count, all.size(), opt.already_done,
               todo.size(), jobs);
  const bool keep = args.keep_logs;
  auto stats = batch::RunPool(
      todo,
      [&args, &cache, keep](const batch::RunPoint& p) {
        return RunOne(p, &cache, args.out + "/runs/" + p.RunId(), keep);
      },
      opt,
      &*db);
  if (!stats.ok()) return stats.status();
  // Exit 1 when any run of this shard failed, including those recorded by an earlier attempt.
  auto rows = db->ReadAll();
  if (!rows.ok()) return rows.status();
  std::set<std::string> mine_ids;
  for (const auto& p : mine) mine_ids.insert(p.RunId());
  size_t failed = 0, present = 0;
  for (const auto& r : *rows) {
    if (!mine_ids.count(r.run_id)) continue;
    ++present;
    if (batch::IsFailure(r.status)) ++failed;
  }
  std::printf("%s: %zu/%zu runs recorded (%zu this time, %.1f s), %zu failed -> %s\n", spec->name.c_str(), present,
              mine.size(), stats->finished, stats->wall_s, failed, db_path.c_str());
  *exit_code = failed > 0 ? 1 : 0;
  return Status::Ok();
}

// ---- batch-report ----

struct ReportArgs {
  std::string dir;
  std::string json_path;
  bool plots = true;
};

Status ReportCommand(const ReportArgs& args, int* exit_code) {
  const std::string db_path = fs::is_regular_file(args.dir) ? args.dir : args.dir + "/" + kResultsFile;
  std::error_code ec;
  if (!fs::is_regular_file(db_path, ec)) return Status::BadInput(db_path + ": no such results file");
  auto db = batch::ResultsDb::Open(db_path, /*create=*/false);
  if (!db.ok()) return db.status();
  auto rows = db->ReadAll();
  if (!rows.ok()) return rows.status();
  if (rows->empty()) return Status::BadInput(db_path + ": holds no runs");
  const auto groups = batch::AggregateRuns(*rows);
  for (const std::string& sentence : reports::BatchHeadline(groups)) std::printf("%s\n", sentence.c_str());
  std::fputs(reports::NumberedReportTable(groups).c_str(), stdout);
  const std::string dir = fs::is_directory(args.dir) ? args.dir : DirName(db_path);
  const std::string json_path = args.json_path.empty() ? dir + "/report.json" : args.json_path;
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(json_path, batch::ReportJson(groups).dump(2) + "\n"));
  *exit_code = 0;
  bool figure = false;
  if (args.plots) {
    const Status s = reports::WriteBatchReportFigure(groups, dir + "/report.png");
    figure = s.ok();
    if (!s.ok()) {
      std::fprintf(stderr, "hexsim: batch-report: plots not written: %s\n", s.message().c_str());
      *exit_code = 1;
    }
  }
  return reports::WriteBatchReportHtml(groups, figure ? "report.png" : "", dir + "/report.html");
}

// ---- batch-merge ----

struct MergeArgs {
  std::string out;
  std::vector<std::string> shards;
};

Status MergeCommand(const MergeArgs& args, int* exit_code) {
  std::vector<std::string> files;
  for (const auto& s : args.shards) {
    const std::string f = fs::is_directory(s) ? s + "/" + kResultsFile : s;
    std::error_code ec;
    if (!fs::is_regular_file(f, ec)) return Status::BadInput(f + ": no such results file");
    auto check = batch::ResultsDb::Open(f, /*create=*/false);
    if (!check.ok()) return check.status();
    files.push_back(f);
  }
  OutputDirectory out;
  HEXSIM_RETURN_IF_ERROR(out.Open(args.out));
  // Built under a temporary name and renamed, so a killed merge never looks finished.
  const std::string final_path = out.File(kResultsFile);
  const std::string tmp = final_path + ".tmp." + std::to_string(getpid());
  int64_t total_in = 0;
  {
    auto db = batch::ResultsDb::Open(tmp, /*create=*/true);
    if (!db.ok()) return db.status();
    std::error_code ec;
    if (fs::is_regular_file(final_path, ec)) {  // merging into an existing result: keep its rows
      int64_t added = 0;
      HEXSIM_RETURN_IF_ERROR(db->MergeFrom(final_path, &added));
    }
    for (const auto& f : files) {
      int64_t added = 0;
      HEXSIM_RETURN_IF_ERROR(db->MergeFrom(f, &added));
      auto n = batch::ResultsDb::Open(f, false)->Count();
      total_in += n.ok() ? *n : 0;
      std::fprintf(stderr, "hexsim batch-merge: %s: %lld new runs\n", f.c_str(), static_cast<long long>(added));
    }
    auto count = db->Count();
    if (!count.ok()) return count.status();
    std::printf("merged %zu shards: %lld rows in, %lld distinct runs -> %s\n", files.size(),
                static_cast<long long>(total_in), static_cast<long long>(*count), final_path.c_str());
  }  // closed: the WAL is checkpointed into the file
  std::error_code ec;
  fs::rename(tmp, final_path, ec);
  if (ec) return Status::BadInput(final_path + ": cannot rename: " + ec.message());
  out.Commit();
  *exit_code = 0;
  return Status::Ok();
}

}  // namespace

void AddBatchCommands(CLI::App& app, int* exit_code) {
  auto args = std::make_shared<BatchArgs>();
  CLI::App* cmd = app.add_subcommand("batch", "Run many missions headless, in parallel, resumably; writes results.sqlite");
  cmd->add_option("batch", args->batch_file, "Batch file: a name under worlds/batches/ or a YAML path")->required();
  cmd->add_option("--jobs,-j", args->jobs, "Worker processes (default: every core)");
  cmd->add_option("--shard", args->shard, "Run only part i of N (0-based, as SLURM_ARRAY_TASK_ID): run k goes to k mod N")
      ->capture_default_str();
  cmd->add_flag("--resume", args->resume, "Continue a batch in --out: skip the runs recorded there");
  cmd->add_option("--run-timeout", args->run_timeout_s, "Kill a run after this many wall seconds (0: never)");
  cmd->add_flag("--keep-logs", args->keep_logs, "Also write each run's log.csv under DIR/runs/<run_id>/");
  cmd->add_flag("--list", args->list, "Print this shard's run ids and parameters; run nothing, write nothing");
  cmd->add_option("--out", args->out, "Output directory");
  cmd->callback([args, exit_code] {
    const Status s = BatchCommand(*args, exit_code);
    if (!s.ok()) *exit_code = Report(s);
  });

  auto rargs = std::make_shared<ReportArgs>();
  CLI::App* rep = app.add_subcommand("batch-report", "Aggregate a batch's results per group: table, report.json, report.png, report.html");
  rep->add_option("dir", rargs->dir, "Batch output directory (or a results.sqlite)")->required();
  rep->add_option("--json", rargs->json_path, "Write the JSON here (default DIR/report.json)");
  rep->add_flag("!--no-plots", rargs->plots, "Skip report.png");
  rep->callback([rargs, exit_code] {
    const Status s = ReportCommand(*rargs, exit_code);
    if (!s.ok()) *exit_code = Report(s);
  });

  auto margs = std::make_shared<MergeArgs>();
  CLI::App* mrg = app.add_subcommand("batch-merge", "Merge shards' results.sqlite into OUT/results.sqlite (dedupe on run_id)");
  mrg->add_option("out", margs->out, "Output directory")->required();
  mrg->add_option("shards", margs->shards, "Shard output directories (or results.sqlite files)")->required();
  mrg->callback([margs, exit_code] {
    const Status s = MergeCommand(*margs, exit_code);
    if (!s.ok()) *exit_code = Report(s);
  });
}

}  // namespace hexsim::app
