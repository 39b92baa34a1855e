// hexsim batch BATCH.yaml [--jobs N] [--shard i/N] [--resume] [--run-timeout S] [--keep-logs] [--list] --out DIR
// hexsim batch-merge OUT SHARD_DIR...
#include <signal.h>  // NOLINT(modernize-deprecated-headers): sigaction is POSIX, not in <csignal>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "cli_util.h"
#include "commands.h"
#include "hexsim/batch/batch_spec.h"
#include "hexsim/experiments/batch_flow.h"

namespace hexsim::app {

namespace {

// SIGINT/SIGTERM while a batch runs (CONTRACTS: exit 130): counted here, acted on by the pool.
volatile std::sig_atomic_t g_interrupts = 0;

extern "C" void OnInterrupt(int /*sig*/) {
  g_interrupts = g_interrupts + 1;
  static const char kFirst[] =
      "\nhexsim batch: interrupted: starting no more runs; the running ones finish (interrupt again to kill them)\n";
  static const char kSecond[] = "\nhexsim batch: interrupted again: killing the running runs\n";
  // write(2) is async-signal-safe; a failed write has nowhere better to be reported.
  const ssize_t ignored = g_interrupts == 1 ? write(STDERR_FILENO, kFirst, sizeof(kFirst) - 1)
                                            : write(STDERR_FILENO, kSecond, sizeof(kSecond) - 1);
  (void)ignored;
}

// Installs OnInterrupt for SIGINT and SIGTERM while it lives (no SA_RESTART: the pool polls anyway).
class InterruptHandlers {
 public:
  InterruptHandlers() {
    struct sigaction sa {};
    sa.sa_handler = OnInterrupt;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, &old_int_);
    sigaction(SIGTERM, &sa, &old_term_);
  }
  ~InterruptHandlers() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }
  InterruptHandlers(const InterruptHandlers&) = delete;
  InterruptHandlers& operator=(const InterruptHandlers&) = delete;

 private:
  struct sigaction old_int_ {};
  struct sigaction old_term_ {};
};

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
  experiments::BatchFlowOptions o;
  o.jobs = args.jobs > 0 ? args.jobs : std::max(1, static_cast<int>(sysconf(_SC_NPROCESSORS_ONLN)));
  o.out = args.out;
  o.resume = args.resume;
  o.keep_logs = args.keep_logs;
  o.run_timeout_s = args.run_timeout_s;
  o.progress_tty = isatty(STDERR_FILENO) == 1;
  o.stop = &g_interrupts;
  const InterruptHandlers handlers;
  auto r = experiments::RunBatch(spec->file, mine, o, [&](const experiments::BatchPlan& plan) {
    std::fprintf(stderr, "hexsim batch: %s: %zu runs (shard %d/%d of %zu), %zu finished before, %zu to run on %d jobs\n",
                 spec->name.c_str(), mine.size(), shard->index, shard->count, all.size(), plan.already_done,
                 plan.to_run, o.jobs);
  });
  if (!r.ok()) return r.status();
  if (r->interrupted) {
    std::fprintf(stderr,
                 "hexsim batch: interrupted: %zu/%zu runs recorded in %s, %zu not run; continue with:\n"
                 "  hexsim batch %s --out %s --resume%s\n",
                 r->recorded, mine.size(), r->db_path.c_str(), r->not_run, args.batch_file.c_str(), args.out.c_str(),
                 args.shard == "0/1" ? "" : (" --shard " + args.shard).c_str());
    *exit_code = kExitInterrupted;
    return Status::Ok();
  }
  std::printf("%s: %zu/%zu runs recorded (%zu this time, %.1f s), %zu failed -> %s\n", spec->name.c_str(), r->recorded,
              mine.size(), r->finished, r->wall_s, r->failed, r->db_path.c_str());
  *exit_code = r->failed > 0 ? 1 : 0;
  return Status::Ok();
}

// ---- batch-merge ----

struct MergeArgs {
  std::string out;
  std::vector<std::string> shards;
};

Status MergeCommand(const MergeArgs& args, int* exit_code) {
  auto r = experiments::MergeShards(args.out, args.shards, [](const std::string& file, long long added) {
    std::fprintf(stderr, "hexsim batch-merge: %s: %lld new runs\n", file.c_str(), added);
  });
  if (!r.ok()) return r.status();
  std::printf("merged %zu shards: %lld rows in, %lld distinct runs -> %s\n", r->shards, r->rows_in, r->distinct_runs,
              r->path.c_str());
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

  AddBatchReportCommand(app, exit_code);  // cmd_batch_report.cc; --help lists batch, batch-report, batch-merge

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
