// `hexsim batch` and `hexsim batch-merge` as library calls: every point of a shard validated up
// front (bad input fails the batch before any run: exit 2, nothing written), OUT/results.sqlite
// opened (or resumed), the points not recorded there flown on batch's forked process pool, and the
// shard's outcome counted; shards' results merged into one file under a temporary name.
#pragma once

#include <csignal>
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "hexsim/batch/batch_spec.h"
#include "hexsim/common/status.h"

namespace hexsim::experiments {

inline constexpr const char* kResultsFile = "results.sqlite";

struct BatchFlowOptions {
  int jobs = 1;
  std::string out;             // the batch's output directory
  bool resume = false;         // an existing OUT/results.sqlite is finished rather than refused
  bool keep_logs = false;      // also OUT/runs/<run_id>/log.csv
  double run_timeout_s = 0.0;  // 0: never
  bool progress_tty = false;
  // SIGINT/SIGTERM count from the caller's handler (batch::PoolOptions::stop); null: not handled.
  const volatile std::sig_atomic_t* stop = nullptr;
};

// What is about to run (passed to the caller before the pool starts).
struct BatchPlan {
  std::string db_path;
  size_t already_done = 0;  // points of the shard recorded by an earlier attempt
  size_t to_run = 0;
};

struct BatchOutcome {
  std::string db_path;
  size_t recorded = 0;  // points of the shard now in the results, this attempt's and earlier ones
  size_t failed = 0;    // of those, failed runs (exit 1 when any)
  size_t finished = 0;  // this attempt
  double wall_s = 0.0;
  bool interrupted = false;  // stopped by a signal: `not_run` points are left for --resume
  size_t not_run = 0;
};

// `batch_file` names the batch in error messages; `points` is this shard's part of it.
Result<BatchOutcome> RunBatch(const std::string& batch_file, const std::vector<batch::RunPoint>& points,
                              const BatchFlowOptions& options, const std::function<void(const BatchPlan&)>& on_plan);

struct MergeOutcome {
  std::string path;  // OUT/results.sqlite
  size_t shards = 0;
  long long rows_in = 0, distinct_runs = 0;
};
// Merges the shards (directories holding results.sqlite, or the files) into OUT/results.sqlite,
// keeping what that file held, deduplicated on run_id; built under a temporary name and renamed.
// `on_shard(file, new_runs)` reports each shard as it is merged.
Result<MergeOutcome> MergeShards(const std::string& out, const std::vector<std::string>& shards,
                                 const std::function<void(const std::string&, long long)>& on_shard);

}  // namespace hexsim::experiments
