// The process pool: each run in its own forked worker process (a crash, abort or runaway in one run
// never takes the batch down), at most `jobs` at a time. The parent alone writes results.sqlite,
// one transaction per finished run.
#pragma once

#include <csignal>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hexsim/batch/batch_spec.h"
#include "hexsim/batch/results_db.h"
#include "hexsim/common/status.h"
#include "hexsim/logs/flight_log.h"

namespace hexsim::batch {

struct PoolOptions {
  int jobs = 1;
  std::string out_dir;        // workers write out_dir/runs/<run_id>/summary.json, or under run_dir(point)
  std::function<std::string(const RunPoint&)> run_dir;  // empty: out_dir/runs/<run_id>
  double run_timeout_s = 0.0; // > 0: a run still going after this long is killed, status "timeout"
  // Progress on `progress_stream` (null: none): a bar when `progress_tty`, else one line per finished run.
  std::FILE* progress_stream = stderr;
  bool progress_tty = false;
  size_t already_done = 0;    // runs of this shard found finished before (resume), for the bar
  // Interruption (CONTRACTS: exit 130), counted by the caller's SIGINT/SIGTERM handler; null: none.
  // Given, the workers ignore SIGINT and SIGTERM (a terminal's Ctrl-C reaches the whole process
  // group) and die with the parent. At 1 no further run starts and the running ones finish and are
  // recorded; at 2 they are killed, not recorded, and their folders removed.
  const volatile std::sig_atomic_t* stop = nullptr;
  // The runs whose flight the parent gets back (empty: none): their RunFn leaves it in the run's
  // folder as log.csv (logs::WriteFlightLog), which the pool reads back typed for `record`.
  std::function<bool(const RunPoint&)> return_log;
};

// Runs inside the worker process: the run's summary (hexsim.summary/1), or why there is none.
using RunFn = std::function<Result<nlohmann::json>(const RunPoint&)>;

struct PoolStats {
  size_t finished = 0;   // rows written by this call
  size_t failed = 0;     // of them, IsFailure(status)
  bool interrupted = false;  // options.stop was raised: some runs were not started (or were killed)
  size_t not_run = 0;        // runs neither recorded nor left running: never started, or killed
  double wall_s = 0.0;
};

// What a finished run hands the parent, typed: the summary.json its worker wrote, and its log.csv
// when PoolOptions::return_log asked for it. Each crosses the process boundary once, as that file.
struct RunResult {
  sim::RunSummary summary;
  std::optional<logs::FlightLog> log;
};

// Runs in the parent as each run ends: its row, and its result (null when it left none; a run asked
// for its log that left none unreadable is "crashed"). `record` may move from the result. An error
// stops new runs from starting; the running ones are still collected.
using RecordFn = std::function<Status(const RunRow& row, RunResult* result)>;

// Runs every point, at most options.jobs at a time, each in a forked worker, and records each as it ends.
Result<PoolStats> RunPool(const std::vector<RunPoint>& runs, const RunFn& fn, const PoolOptions& options,
                          const RecordFn& record);
// The same, recording each run in `db` (none of the points may be in it already).
Result<PoolStats> RunPool(const std::vector<RunPoint>& runs, const RunFn& fn, const PoolOptions& options,
                          ResultsDb* db);

// The pool's core, for any kind of task: forks a worker for each i in [0, n), in order, at most
// `jobs` at a time. In the parent `before_fork(i)` runs first (an error stops new workers); the
// worker runs `child(i)` and exits with the code it returns (an exception: code 5) without running
// atexit handlers; as each worker ends the parent gets `reaped(i, wait status, wall s, timed out)`
// (an error stops new workers; the running ones are still reaped). timeout_s > 0: a worker still
// running after that long is killed (SIGKILL). `stop` (may be null): as PoolOptions::stop; a worker
// killed at *stop >= 2 is reaped with `killed` set. Returns the first error.
using ReapFn = std::function<Status(size_t index, int wait_status, double wall_s, bool timed_out)>;
Status ForkEach(size_t n, int jobs, double timeout_s, const std::function<Status(size_t)>& before_fork,
                const std::function<int(size_t)>& child, const ReapFn& reaped,
                const volatile std::sig_atomic_t* stop = nullptr,
                const std::function<void(size_t index)>& killed = {});

// fn(i) for every i in [0, n) in forked workers (at most `jobs` at a time; a crash in one never takes
// the caller down), each JSON result passed back through a temporary file; the results in index
// order, whatever order the workers end in. Any task's failure (its error, a crash) fails the call:
// the first failure in index order. `progress` (may be empty) is called in the parent as each ends.
Result<std::vector<nlohmann::json>> RunForkedMap(size_t n, const std::function<Result<nlohmann::json>(size_t)>& fn,
                                                 int jobs,
                                                 const std::function<void(size_t done, size_t total)>& progress = {});

// The parameters that differ between `runs` (world, estimator, duration and --set keys; mission,
// vehicle, calibration and seed are always shown), in key order: what tells one progress line's
// point from another's in a grid ("adaptive seed 1" appears once per grid point).
std::vector<std::string> VariedParameters(const std::vector<RunPoint>& runs);
// " key=value" for each of `keys` in the point's parameters.
std::string VariedText(const RunPoint& point, const std::vector<std::string>& keys);

// The progress display (exposed for tests).
class Progress {
 public:
  Progress(std::FILE* out, bool tty, size_t total, size_t already_done);
  // `varied`: VariedText of the run's point, printed after its calibration and seed.
  void RunFinished(const RunRow& row, const std::string& varied = "");
  void Finish();
  // "0:07", "1:02:03"
  static std::string FormatDuration(double seconds);

 private:
  std::FILE* out_;
  bool tty_;
  size_t total_, done_, failed_ = 0, done_here_ = 0;
  double start_s_;
};

}  // namespace hexsim::batch
