#include "hexsim/batch/pool.h"

#include <signal.h>  // NOLINT(modernize-deprecated-headers): sigaction, kill are POSIX
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <cmath>
#include <cstdlib>
#include <map>
#include <set>
#include <thread>

#include <gtest/gtest.h>

#include "test_util.h"

namespace hexsim::batch {
namespace {

using nlohmann::json;

std::vector<RunPoint> Points(int n) {
  std::vector<RunPoint> out;
  for (int i = 1; i <= n; ++i) {
    RunPoint p;
    p.seed = static_cast<uint64_t>(i);
    out.push_back(p);
  }
  return out;
}

// `jobs` workers running into `dir`, without progress lines.
PoolOptions Quiet(const std::string& dir, int jobs) {
  PoolOptions opt;
  opt.jobs = jobs;
  opt.out_dir = dir;
  opt.progress_stream = nullptr;
  return opt;
}

// A stand-in for a mission: a summary that depends only on the point; seed 3 aborts (a crash),
// seed 4 reports an error, seed 5 diverges.
Result<json> FakeRun(const RunPoint& p) {
  if (p.seed == 3) std::abort();
  if (p.seed == 4) return Status::BadInput("mission file vanished");
  const double s = static_cast<double>(p.seed);
  sim::RunSummary sum;
  sum.status = p.seed == 5 ? sim::RunStatus::kDiverged : sim::RunStatus::kCompleted;
  sum.reason = p.seed == 5 ? "non-finite v_N_mps at t = 1.000 s" : "";
  sum.mission = p.mission;
  sum.cross_track_m = {2 * s, s};
  sum.yaw_error_deg = {0.5 * s, 0.25 * s};
  sum.energy_Wh = 1.5 + s;
  sum.duration_s = 10.0;
  sum.wall_s = 0.01 * s;
  sum.version = "test";
  return sim::ToJson(sum);
}

std::vector<std::string> RunWithJobs(int jobs, const std::string& name, PoolStats* stats_out) {
  const std::string dir = testing::TempDir(name);
  auto db = ResultsDb::Open(dir + "/results.sqlite", true);
  EXPECT_TRUE(db.ok());
  PoolOptions opt = Quiet(dir, jobs);
  auto stats = RunPool(Points(8), FakeRun, opt, &*db);
  EXPECT_TRUE(stats.ok()) << stats.status().message();
  if (stats.ok()) *stats_out = *stats;
  return testing::ComparableTable(dir + "/results.sqlite");
}

TEST(RunPool, GivenRunsThatCrashFailAndDivergeWhenPooledThenEachIsRecordedWithItsReasonAndTheRestFinish) {
  const std::string dir = testing::TempDir("pool_failures");
  auto db = ResultsDb::Open(dir + "/results.sqlite", true);
  ASSERT_TRUE(db.ok());
  PoolOptions opt = Quiet(dir, 2);
  auto stats = RunPool(Points(8), FakeRun, opt, &*db);
  ASSERT_TRUE(stats.ok()) << stats.status().message();
  EXPECT_EQ(stats->finished, 8u);
  EXPECT_EQ(stats->failed, 3u);
  auto rows = db->ReadAll();
  ASSERT_TRUE(rows.ok());
  ASSERT_EQ(rows->size(), 8u);
  for (const auto& r : *rows) {
    SCOPED_TRACE(r.seed);
    switch (r.seed) {
      case 3:
        EXPECT_EQ(r.status, "crashed");
        EXPECT_NE(r.reason.find("signal 6"), std::string::npos) << r.reason;
        EXPECT_FALSE(r.metrics.at("cross_track_rms_m").has_value());
        break;
      case 4:
        EXPECT_EQ(r.status, "failed");
        EXPECT_EQ(r.reason, "mission file vanished");
        break;
      case 5:
        EXPECT_EQ(r.status, "diverged");
        EXPECT_NE(r.reason.find("non-finite"), std::string::npos);
        break;
      default:
        EXPECT_EQ(r.status, "completed");
        ASSERT_TRUE(r.metrics.at("cross_track_rms_m").has_value());
        EXPECT_DOUBLE_EQ(*r.metrics.at("cross_track_rms_m"), static_cast<double>(r.seed));
        EXPECT_DOUBLE_EQ(*r.metrics.at("energy_Wh"), 1.5 + static_cast<double>(r.seed));
        EXPECT_FALSE(r.metrics.at("mission_time_s").has_value());
        EXPECT_EQ(r.summary_json.find("wall_s"), std::string::npos);  // kept out of the comparable columns
    }
    EXPECT_EQ(r.run_id, RunPoint{Points(8)[r.seed - 1]}.RunId());
  }
}

TEST(RunPool, GivenOneOrTwoWorkersWhenTheSameRunsArePooledThenTheTablesAreIdentical) {
  PoolStats s1, s2;
  const auto one = RunWithJobs(1, "pool_jobs1", &s1);
  const auto two = RunWithJobs(2, "pool_jobs2", &s2);
  ASSERT_EQ(one.size(), 8u);
  EXPECT_EQ(one, two);
}

TEST(RunPool, GivenARunThatHangsWhenATimeoutIsSetThenItIsKilledAndRecordedAsTimeout) {
  const std::string dir = testing::TempDir("pool_timeout");
  auto db = ResultsDb::Open(dir + "/results.sqlite", true);
  ASSERT_TRUE(db.ok());
  PoolOptions opt = Quiet(dir, 2);
  opt.run_timeout_s = 0.3;
  auto hang = [](const RunPoint& p) -> Result<json> {
    if (p.seed == 1) std::this_thread::sleep_for(std::chrono::seconds(30));
    sim::RunSummary done;
    done.status = sim::RunStatus::kCompleted;
    return sim::ToJson(done);
  };
  const auto t0 = std::chrono::steady_clock::now();
  auto stats = RunPool(Points(2), hang, opt, &*db);
  const double took_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_TRUE(stats.ok());
  EXPECT_LT(took_s, 10.0);
  auto rows = db->ReadAll();
  ASSERT_TRUE(rows.ok());
  ASSERT_EQ(rows->size(), 2u);
  for (const auto& r : *rows) EXPECT_EQ(r.status, r.seed == 1 ? "timeout" : "completed");
}

// The parent gets each run's summary typed, as the worker's summary.json read back once (compare
// used to turn it into JSON and straight back into a struct); none for a run that left none.
TEST(RunPool, GivenFinishedAndCrashedRunsWhenRecordedThenEachFinishedRunsSummaryArrivesTyped) {
  const std::string dir = testing::TempDir("pool_typed");
  PoolOptions opt = Quiet(dir, 2);
  std::map<uint64_t, double> energy;
  std::set<uint64_t> without;
  auto stats = RunPool(Points(4), FakeRun, opt, [&](const RunRow& row, RunResult* r) {
    if (r == nullptr) {
      without.insert(row.seed);
    } else {
      energy[row.seed] = r->summary.energy_Wh;
      EXPECT_FALSE(r->log.has_value());  // nobody asked for it
    }
    return Status::Ok();
  });
  ASSERT_TRUE(stats.ok());
  EXPECT_EQ(without, (std::set<uint64_t>{3, 4}));  // 3 aborts, 4 reports an error
  ASSERT_EQ(energy.size(), 2u);
  EXPECT_DOUBLE_EQ(energy[1], 2.5);
  EXPECT_DOUBLE_EQ(energy[2], 3.5);
}

// A flight whose values need every digit (thirds, a subnormal, a negative zero, NaN): what a worker
// of seed s flies in memory, and leaves as its run's log.csv when seed s is not 2.
logs::FlightLog FakeFlight(uint64_t seed) {
  logs::FlightLog log;
  log.meta = {{"source", "pool_test"}, {"seed", seed}};
  const double s = static_cast<double>(seed);
  const std::vector<std::vector<double>> rows = {{0.0, s / 3.0, 1e300 * s},
                                                 {0.1, -0.0, -2.0 / 7.0},
                                                 {0.2, 4.9406564584124654e-324, 0.1 + 0.2},
                                                 {1.0 / 3.0, logs::kMissing, std::nextafter(1.0, 2.0)}};
  for (const auto& row : rows) {
    log.AppendRow();
    log.Set("t_s", row[0]);
    log.Set("pos_N_m", row[1]);
    log.Set("yaw_rad", row[2]);
  }
  return log;
}

// The parent gets back, typed, the flights it asked for (compare draws its figures from them; it
// used to read log.csv itself after the pool) and no other; a run asked for a log it did not leave
// is a crashed run, not one with an empty flight.
TEST(RunPool, GivenRunsAskedForTheirFlightWhenRecordedThenEachArrivesTypedAsTheWorkerFlewIt) {
  const std::string dir = testing::TempDir("pool_flight");
  PoolOptions opt = Quiet(dir, 2);
  opt.return_log = [](const RunPoint& p) { return p.seed != 3; };
  std::filesystem::create_directories(dir + "/runs/" + Points(2)[1].RunId());
  ASSERT_TRUE(logs::WriteFlightLog(FakeFlight(99), dir + "/runs/" + Points(2)[1].RunId() + "/log.csv").ok());
  const RunFn run = [&opt](const RunPoint& p) -> Result<json> {
    if (p.seed != 2) HEXSIM_RETURN_IF_ERROR(logs::WriteFlightLog(FakeFlight(p.seed), opt.out_dir + "/runs/" + p.RunId() + "/log.csv"));
    sim::RunSummary sum;
    sum.status = sim::RunStatus::kCompleted;
    return sim::ToJson(sum);
  };
  std::map<uint64_t, logs::FlightLog> flights;
  std::map<uint64_t, std::string> status;
  auto stats = RunPool(Points(3), run, opt, [&](const RunRow& row, RunResult* r) {
    status[row.seed] = row.status + (row.reason.empty() ? "" : ": " + row.reason);
    if (r != nullptr && r->log) flights[row.seed] = std::move(*r->log);
    return Status::Ok();
  });
  ASSERT_TRUE(stats.ok());
  ASSERT_EQ(flights.size(), 1u);  // seed 3 was not asked; seed 2 left none (nor the stale one before it)
  const logs::FlightLog want = FakeFlight(1);
  const logs::FlightLog& got = flights[1];
  EXPECT_EQ(got.meta, want.meta);
  ASSERT_EQ(got.columns(), want.columns());
  ASSERT_EQ(got.rows(), want.rows());
  for (size_t c = 0; c < want.columns().size(); ++c) {
    for (size_t i = 0; i < want.rows(); ++i) {
      const double a = got.At(i, c), b = want.At(i, c);
      if (std::isnan(b)) {
        EXPECT_TRUE(std::isnan(a)) << want.columns()[c] << " row " << i;
      } else {
        EXPECT_TRUE(a == b && std::signbit(a) == std::signbit(b))  // every digit, and the sign of a zero
            << want.columns()[c] << " row " << i << ": " << a << " vs " << b;
      }
    }
  }
  EXPECT_EQ(status[1], "completed");
  EXPECT_EQ(status[3], "completed");
  EXPECT_EQ(status[2].rfind("crashed: unreadable log.csv: ", 0), 0u) << status[2];
}

// Interruption (CONTRACTS: exit 130). The handler counts signals as apps/cmd_batch.cc's does; a worker
// plays the user's Ctrl-C by signalling its parent (and itself: a terminal signals the whole group).
volatile std::sig_atomic_t g_test_interrupts = 0;
extern "C" void CountInterrupt(int /*sig*/) { g_test_interrupts = g_test_interrupts + 1; }

struct CountingHandler {
  CountingHandler() {
    g_test_interrupts = 0;
    struct sigaction sa {};
    sa.sa_handler = CountInterrupt;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, &old);
  }
  ~CountingHandler() { sigaction(SIGINT, &old, nullptr); }
  struct sigaction old {};
};

Result<json> Completed() {
  sim::RunSummary done;
  done.status = sim::RunStatus::kCompleted;
  return sim::ToJson(done);
}

// Pools `n` points of `run` on two workers into DIR/results.sqlite, interruptible by SIGINT.
struct InterruptiblePool {
  std::string dir;
  std::vector<RunPoint> points;
  Result<PoolStats> stats = Status::BadInput("not run");
  std::vector<RunRow> rows;

  InterruptiblePool(const std::string& name, int n, const RunFn& run) : dir(testing::TempDir(name)), points(Points(n)) {
    auto db = ResultsDb::Open(dir + "/results.sqlite", true);
    if (!db.ok()) return;
    PoolOptions opt = Quiet(dir, 2);
    opt.stop = &g_test_interrupts;
    stats = RunPool(points, run, opt, &*db);
    auto read = db->ReadAll();
    if (read.ok()) rows = *read;
  }
};

TEST(RunPool, GivenOneInterruptWhenRunsAreGoingThenNoMoreStartAndTheRunningOnesFinishAndAreRecorded) {
  const CountingHandler handler;
  auto run = [](const RunPoint& p) -> Result<json> {
    if (p.seed == 1) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));  // both workers have started
      kill(getppid(), SIGINT);
      kill(getpid(), SIGINT);  // the worker ignores it and finishes
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    return Completed();
  };
  const InterruptiblePool pool("pool_interrupt_once", 6, run);
  ASSERT_TRUE(pool.stats.ok()) << pool.stats.status().message();
  EXPECT_TRUE(pool.stats->interrupted);
  EXPECT_EQ(pool.stats->finished, 2u);
  EXPECT_EQ(pool.stats->not_run, 4u);
  ASSERT_EQ(pool.rows.size(), 2u);
  for (const auto& r : pool.rows) EXPECT_EQ(r.status, "completed") << r.seed << ": " << r.reason;
  for (size_t i = 2; i < pool.points.size(); ++i) {
    EXPECT_FALSE(std::filesystem::exists(pool.dir + "/runs/" + pool.points[i].RunId())) << "an unstarted run's folder";
  }
}

TEST(RunPool, GivenASecondInterruptWhenRunsAreGoingThenTheyAreKilledNotRecordedAndTheirFoldersRemoved) {
  const CountingHandler handler;
  auto run = [](const RunPoint& p) -> Result<json> {
    if (p.seed == 1) {
      kill(getppid(), SIGINT);
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      kill(getppid(), SIGINT);
    }
    std::this_thread::sleep_for(std::chrono::seconds(30));
    return Completed();
  };
  const auto t0 = std::chrono::steady_clock::now();
  const InterruptiblePool pool("pool_interrupt_twice", 4, run);
  const double took_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_TRUE(pool.stats.ok()) << pool.stats.status().message();
  EXPECT_LT(took_s, 10.0);
  EXPECT_TRUE(pool.stats->interrupted);
  EXPECT_EQ(pool.stats->finished, 0u);
  EXPECT_EQ(pool.stats->not_run, 4u);
  EXPECT_TRUE(pool.rows.empty());
  for (const auto& p : pool.points) EXPECT_FALSE(std::filesystem::exists(pool.dir + "/runs/" + p.RunId()));
}

// Task i sleeps longer the smaller i is, so with two workers the tasks end out of order.
Result<json> SlowFirst(size_t i) {
  std::this_thread::sleep_for(std::chrono::milliseconds(static_cast<int>(40 - 8 * i)));
  return json{{"i", i}, {"square", static_cast<double>(i * i) / 3.0}};
}

TEST(RunForkedMap, GivenTasksEndingOutOfOrderWhenMappedOnOneOrTwoWorkersThenTheResultsAreInTaskOrderAndIdentical) {
  size_t last_done = 0;
  auto one = RunForkedMap(5, SlowFirst, 1);
  auto two = RunForkedMap(5, SlowFirst, 2, [&](size_t done, size_t total) {
    EXPECT_EQ(total, 5u);
    last_done = done;
  });
  ASSERT_TRUE(one.ok()) << one.status().message();
  ASSERT_TRUE(two.ok()) << two.status().message();
  ASSERT_EQ(one->size(), 5u);
  for (size_t i = 0; i < 5; ++i) {
    EXPECT_EQ((*two)[i]["i"].get<size_t>(), i);
    EXPECT_EQ((*two)[i]["square"].get<double>(), static_cast<double>(i * i) / 3.0);  // exact through the file
  }
  EXPECT_EQ(*one, *two);
  EXPECT_EQ(last_done, 5u);
}

TEST(RunForkedMap, GivenTasksThatFailOrCrashWhenMappedThenTheFirstFailureInTaskOrderIsReturned) {
  auto fail = [](size_t i) -> Result<json> {
    if (i == 3) std::abort();
    if (i == 1) return Status::BadInput("task one is bad");
    return json(i);
  };
  auto r = RunForkedMap(4, fail, 2);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().message(), "task one is bad");
  auto crash = RunForkedMap(4, [](size_t i) -> Result<json> {
    if (i == 2) std::abort();
    return json(i);
  }, 2);
  ASSERT_FALSE(crash.ok());
  EXPECT_NE(crash.status().message().find("task 2: worker killed by signal"), std::string::npos) << crash.status().message();
}

TEST(ResultsDb, GivenARowInsertedTwiceWhenReadThenItIsPresentOnceAndTheFirstIsKept) {
  const std::string dir = testing::TempDir("db_dupe");
  auto db = ResultsDb::Open(dir + "/results.sqlite", true);
  ASSERT_TRUE(db.ok());
  RunPoint p;
  bool inserted = false;
  ASSERT_TRUE(db->Insert(FailedRow(p, "crashed", "first", 1.0), &inserted).ok());
  EXPECT_TRUE(inserted);
  ASSERT_TRUE(db->Insert(FailedRow(p, "crashed", "second", 1.0), &inserted).ok());
  EXPECT_FALSE(inserted);
  auto rows = db->ReadAll();
  ASSERT_EQ(rows->size(), 1u);
  EXPECT_EQ((*rows)[0].reason, "first");
}

TEST(ResultsDb, GivenOverlappingShardFilesWhenMergedThenEveryRunIsPresentExactlyOnce) {
  const std::string dir = testing::TempDir("db_merge");
  const auto points = Points(6);
  for (int s = 0; s < 2; ++s) {
    auto db = ResultsDb::Open(dir + "/s" + std::to_string(s) + ".sqlite", true);
    ASSERT_TRUE(db.ok());
    for (size_t i = 0; i < points.size(); ++i) {
      if (i % 2 == static_cast<size_t>(s) || i == 0) {
        ASSERT_TRUE(db->Insert(FailedRow(points[i], "crashed", "x", 0)).ok());
      }
    }
  }
  auto merged = ResultsDb::Open(dir + "/all.sqlite", true);
  ASSERT_TRUE(merged.ok());
  int64_t a = 0, b = 0;
  ASSERT_TRUE(merged->MergeFrom(dir + "/s0.sqlite", &a).ok());
  ASSERT_TRUE(merged->MergeFrom(dir + "/s1.sqlite", &b).ok());
  EXPECT_EQ(a, 3);
  EXPECT_EQ(b, 3);  // point 0 was in both
  EXPECT_EQ(*merged->Count(), 6);
  EXPECT_FALSE(merged->MergeFrom(dir + "/missing.sqlite", &a).ok());
}

// In a grid "adaptive seed 1" appeared once per grid point with nothing to tell them apart: each
// line now carries the parameters that vary across the batch (and only those).
TEST(Progress, GivenAGridWhenARunFinishesThenItsLineShowsTheVariedParameters) {
  std::vector<RunPoint> runs = Points(2);
  for (auto& p : runs) p.sets["world.wind.mean_N_mps"] = json::array({0, 5, 0});
  runs.push_back(runs[0]);
  runs.back().sets["control.rate.roll.kp"] = 0.2;
  runs[0].sets["control.rate.roll.kp"] = 0.1;
  runs[1].sets["control.rate.roll.kp"] = 0.1;
  const std::vector<std::string> varied = VariedParameters(runs);
  EXPECT_EQ(varied, std::vector<std::string>{"control.rate.roll.kp"});
  EXPECT_EQ(VariedText(runs[2], varied), " control.rate.roll.kp=0.2");

  const std::string path = testing::TempDir("progress_grid") + "/progress.txt";
  std::FILE* f = std::fopen(path.c_str(), "w");
  ASSERT_NE(f, nullptr);
  Progress progress(f, /*tty=*/false, runs.size(), 0);
  progress.RunFinished(FailedRow(runs[2], "completed", "", 0.5), VariedText(runs[2], varied));
  std::fclose(f);
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  EXPECT_NE(line.find("none seed 1 control.rate.roll.kp=0.2: completed"), std::string::npos) << line;
}

TEST(Progress, GivenSecondsWhenFormattedThenMinutesAndHoursShow) {
  EXPECT_EQ(Progress::FormatDuration(7), "0:07");
  EXPECT_EQ(Progress::FormatDuration(62), "1:02");
  EXPECT_EQ(Progress::FormatDuration(3723), "1:02:03");
  EXPECT_EQ(Progress::FormatDuration(-1), "--:--");
}

}  // namespace
}  // namespace hexsim::batch
