// Batch scaling: the same 8 missions (10 s or 60 s of the square, ESKF) through the process pool
// with 1 and 2 workers (separate processes, as `hexsim batch` runs them). Compare runs/s.
#include <benchmark/benchmark.h>

#include <unistd.h>

#include <filesystem>
#include <string>

#include "hexsim/batch/pool.h"
#include "hexsim/batch/results_db.h"
#include "hexsim/batch/setup_cache.h"
#include "hexsim/sim/run_config.h"

namespace {

constexpr int kRuns = 8;

// As `hexsim batch` does it: the setup loaded once in the parent, inherited by the forked workers.
nlohmann::json RunOne(const hexsim::batch::RunPoint& p, hexsim::batch::SetupCache* cache) {
  auto setup = cache->Get(p);
  if (!setup.ok()) return {{"status", "failed"}, {"reason", setup.status().message()}};
  return hexsim::sim::ToJson(hexsim::sim::RunMission(*setup).summary);
}

void BM_BatchPool(benchmark::State& state) {
  const int jobs = static_cast<int>(state.range(0));
  const double run_s = static_cast<double>(state.range(1));  // simulated seconds per run
  std::vector<hexsim::batch::RunPoint> points;
  for (int i = 0; i < kRuns; ++i) {
    hexsim::batch::RunPoint p;
    p.estimator = "eskf";
    p.seed = static_cast<uint64_t>(i) + 1;
    p.duration_s = run_s;
    points.push_back(p);
  }
  const std::string dir =
      (std::filesystem::temp_directory_path() / ("hexsim_bench_batch_" + std::to_string(getpid()))).string();
  hexsim::batch::SetupCache cache;
  (void)cache.Get(points[0]);
  size_t runs = 0;
  for (auto _ : state) {
    state.PauseTiming();
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    auto db = hexsim::batch::ResultsDb::Open(dir + "/results.sqlite", true);
    state.ResumeTiming();
    hexsim::batch::PoolOptions opt;
    opt.jobs = jobs;
    opt.out_dir = dir;
    opt.progress_stream = nullptr;
    auto stats = hexsim::batch::RunPool(
        points,
        [&cache](const hexsim::batch::RunPoint& p) -> hexsim::Result<nlohmann::json> { return RunOne(p, &cache); },
        opt,
        &*db);
    if (!stats.ok() || stats->failed) {
      state.SkipWithError("batch runs failed");
      break;
    }
    runs += stats->finished;
  }
  std::filesystem::remove_all(dir);
  state.counters["runs_per_s"] = benchmark::Counter(static_cast<double>(runs), benchmark::Counter::kIsRate);
  state.counters["realtime_x"] =
      benchmark::Counter(static_cast<double>(runs) * run_s, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_BatchPool)->Args({1, 10})->Args({2, 10})->Args({1, 60})->Args({2, 60})->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

}  // namespace

BENCHMARK_MAIN();
