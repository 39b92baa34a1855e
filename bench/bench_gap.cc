// Speed of the gap diagnosis (issue 16: a 10-minute log at log171's rates, all channels, < 2 s),
// beside a reference measured in the same process run (the machine is shared: only ratios taken
// side by side mean anything).
//
// The log: quad_x flies the square's four legs over and over for 600 s (truth estimator, seed 1),
// logged with native-rate imu, rcou and batt streams at 50 Hz (sim.stream_rate_hz); the single
// table is then kept at 10 Hz (every tenth 100 Hz row: compass, attitude, current, throttle at
// 10 Hz, as log171 logs them). Built once, before the timed cases.
//   BM_GapReadLog10min   the reference: reading that log back from its CSV files (table, streams,
//                        meta), i.e. what `hexsim gap diagnose` does before diagnosing.
//   BM_GapDiagnose10min  gap::Diagnose on it against the configured quad_x: every channel (three
//                        compasses with timing scans, gyro, accel, dynamics), gap.json built.
//   BM_GapDiagnoseLogSim10min    `hexsim gap diagnose --sim quad_x`'s whole flow after the read, its
//                        channels on every core as the CLI's default (CPU summed over the threads)
//                        (experiments::DiagnoseLog: the diagnosis, the vehicle identified from the
//                        log to report its distance from quad_x, the updated YAML), gap.json built.
//   BM_GapDiagnoseLogNoSim10min  the same without --sim: the frame picks the base, the vehicle is
//                        identified on the even blocks and the odd blocks are diagnosed.
// After the run: each case in CPU and wall seconds, the diagnoses as multiples of the read time;
// the goal is < 2 s wall for each path (read + flow).
#include <benchmark/benchmark.h>

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>

#include "hexsim/experiments/log_diagnosis.h"
#include "hexsim/gap/diagnose.h"
#include "hexsim/gap/json.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/sim/run_config.h"
#include "hexsim/sim/simulation.h"

namespace {

constexpr double kLogSeconds = 600.0;
constexpr size_t kRowDecimation = 10;  // 100 Hz simulator rows -> 10 Hz
constexpr double kStreamRate_hz = 50.0;

[[noreturn]] void Die(const std::string& what) {
  std::fprintf(stderr, "bench_gap: %s\n", what.c_str());
  std::abort();
}

std::string g_dir;  // the CSV files' directory, removed at exit

struct BenchLog {
  hexsim::logs::FlightLog log;
  hexsim::vehicle::VehicleParams vehicle;
  std::string csv_path;
};

// The 10-minute log (see the file comment), and its CSV files in a per-process directory.
const BenchLog& TenMinuteLog() {
  static const BenchLog kLog = [] {
    hexsim::sim::RunRequest req;
    req.mission = "square";
    req.vehicle = "quad_x";
    req.world = "default";
    req.estimator = "truth";
    req.seed = 1;
    req.duration_s = kLogSeconds;
    auto setup = hexsim::sim::LoadRunSetup(req);
    if (!setup.ok()) Die(setup.status().message());
    // take-off, the four corners repeated until the duration ends the run (each lap ≈ 40 s), land.
    auto& items = setup->mission.items;
    if (items.size() < 3) Die("the square mission changed shape");
    const std::vector<hexsim::control::MissionItem> legs(items.begin() + 1, items.end() - 1);
    const hexsim::control::MissionItem land = items.back();
    items.resize(1);
    for (int lap = 0; lap < 20; ++lap) items.insert(items.end(), legs.begin(), legs.end());
    items.push_back(land);
    setup->options.stream_rate_hz = kStreamRate_hz;
    auto out = hexsim::sim::RunMission(*setup);
    if (!out.status.ok()) Die(out.status.message());
    BenchLog b;
    b.vehicle = setup->vehicle;
    const hexsim::logs::FlightLog& full = out.log;
    for (const auto& name : full.columns()) b.log.AddColumn(name);
    for (size_t i = 0; i < full.rows(); i += kRowDecimation) {
      b.log.AppendRow();
      for (size_t c = 0; c < full.columns().size(); ++c) b.log.Set(c, full.At(i, c));
    }
    b.log.meta = full.meta;
    for (const auto& s : full.stream_names()) b.log.SetStream(s, *full.Stream(s));
    const auto dir = std::filesystem::temp_directory_path() / ("hexsim_bench_gap_" + std::to_string(getpid()));
    std::filesystem::create_directories(dir);
    g_dir = dir.string();
    b.csv_path = (dir / "log.csv").string();
    const auto st = hexsim::logs::WriteFlightLog(b.log, b.csv_path);
    if (!st.ok()) Die(st.message());
    return b;
  }();
  return kLog;
}

void Describe(benchmark::State& state, const BenchLog& b) {
  const auto& t = b.log.Column("t_s");
  const auto* imu = b.log.Stream("imu");
  state.counters["log_s"] = t.back() - t.front();
  state.counters["rows"] = static_cast<double>(b.log.rows());
  state.counters["imu_rows"] = imu ? static_cast<double>(imu->rows()) : 0.0;
}

void BM_GapReadLog10min(benchmark::State& state) {
  const BenchLog& b = TenMinuteLog();
  for (auto _ : state) {
    auto log = hexsim::logs::ReadFlightLog(b.csv_path);
    if (!log.ok()) {
      state.SkipWithError(log.status().message().c_str());
      break;
    }
    benchmark::DoNotOptimize(log->rows());
  }
  Describe(state, b);
  state.SetLabel("read table + streams + meta (reference)");
}
BENCHMARK(BM_GapReadLog10min)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();

void BM_GapDiagnose10min(benchmark::State& state) {
  const BenchLog& b = TenMinuteLog();
  size_t channels = 0;
  std::string names;
  for (auto _ : state) {
    auto rep = hexsim::gap::Diagnose(b.log, b.vehicle);
    if (!rep.ok()) {
      state.SkipWithError(rep.status().message().c_str());
      break;
    }
    channels = rep->channels.size();
    names.clear();
    for (const auto& c : rep->channels) {
      if (!names.empty()) names += ",";
      names += c.channel;
    }
    for (const auto& [c, why] : rep->not_diagnosed) names.append(" (not ").append(c).append(": ").append(why).append(")");
    benchmark::DoNotOptimize(hexsim::gap::ToJson(*rep));
  }
  Describe(state, b);
  state.counters["channels"] = static_cast<double>(channels);
  state.SetLabel(names + "; gap.json built");
}
BENCHMARK(BM_GapDiagnose10min)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();

// The CLI's flow on the log (`vehicle` "" = without --sim); the label says how the vehicle was chosen.
void DiagnoseLogCase(benchmark::State& state, const std::string& vehicle) {
  const BenchLog& b = TenMinuteLog();
  hexsim::experiments::LogDiagnosisOptions o;
  o.vehicle = vehicle;
  o.log_name = b.csv_path;
  o.threads = std::max(1, static_cast<int>(sysconf(_SC_NPROCESSORS_ONLN)));  // the CLI's default (--jobs 0)
  std::string mode;
  size_t channels = 0;
  for (auto _ : state) {
    auto d = hexsim::experiments::DiagnoseLog(b.log, o);
    if (!d.ok()) {
      state.SkipWithError(d.status().message().c_str());
      break;
    }
    channels = d->report.channels.size();
    mode = d->vehicle_source.value("mode", std::string());
    benchmark::DoNotOptimize(hexsim::experiments::LogDiagnosisJson(*d).dump());
  }
  Describe(state, b);
  state.counters["channels"] = static_cast<double>(channels);
  state.SetLabel("vehicle: " + mode + "; gap.json built");
}
void BM_GapDiagnoseLogSim10min(benchmark::State& state) { DiagnoseLogCase(state, "quad_x"); }
BENCHMARK(BM_GapDiagnoseLogSim10min)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();
void BM_GapDiagnoseLogNoSim10min(benchmark::State& state) { DiagnoseLogCase(state, ""); }
BENCHMARK(BM_GapDiagnoseLogNoSim10min)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();

// Console output as usual; CPU and wall time of each case kept for the ratio line.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& r : runs) {
      if (r.error_occurred) continue;
      const bool single = r.run_type == Run::RT_Iteration && r.repetitions <= 1;
      const bool median = r.run_type == Run::RT_Aggregate && r.aggregate_name == "median";
      if (!single && !median) continue;
      const double unit = benchmark::GetTimeUnitMultiplier(r.time_unit);
      cpu_s_[r.run_name.function_name] = r.GetAdjustedCPUTime() / unit;
      wall_s_[r.run_name.function_name] = r.GetAdjustedRealTime() / unit;
    }
    ConsoleReporter::ReportRuns(runs);
  }
  void PrintRatios() const {
    const auto read = cpu_s_.find("BM_GapReadLog10min");
    if (read == cpu_s_.end()) return;
    const double read_wall = wall_s_.at(read->first);
    std::printf("\n10-minute log at log171's rates, same process run (CPU s / wall s):\n");
    std::printf("  read (reference)            %.3f / %.3f\n", read->second, read_wall);
    const char* const kCases[][2] = {{"BM_GapDiagnose10min", "gap::Diagnose"},
                                     {"BM_GapDiagnoseLogSim10min", "with --sim"},
                                     {"BM_GapDiagnoseLogNoSim10min", "without --sim"}};
    for (const auto& [name, what] : kCases) {
      const auto c = cpu_s_.find(name);
      if (c == cpu_s_.end()) continue;
      const double wall = wall_s_.at(name);
      std::printf("  %-26s  %.3f / %.3f   = %.2f x the read (CPU); read + this %.3f s wall%s\n", what, c->second,
                  wall, c->second / read->second, read_wall + wall,
                  std::string(what) == "gap::Diagnose" ? "" : (read_wall + wall < 2.0 ? " (< 2 s: met)" : " (goal < 2 s: missed)"));
    }
  }

 private:
  std::map<std::string, double> cpu_s_, wall_s_;
};

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  reporter.PrintRatios();
  std::error_code ec;
  if (!g_dir.empty()) std::filesystem::remove_all(g_dir, ec);
  benchmark::Shutdown();
  return 0;
}
