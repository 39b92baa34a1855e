// End-to-end: the `hexsim batch`, `batch-merge` and `batch-report` commands on short real missions.
#include <fcntl.h>
#include <signal.h>  // NOLINT(modernize-deprecated-headers): POSIX header for kill(); <csignal> does not declare it
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <set>
#include <thread>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "hexsim/batch/batch_spec.h"
#include "hexsim/batch/results_db.h"
#include "test_util.h"

namespace hexsim::batch {
namespace {

namespace fs = std::filesystem;
using testing::ComparableTable;
using testing::DataFile;
using testing::Hexsim;
using testing::TempDir;

std::set<std::string> ExpectedIds(const std::string& batch_file) {
  auto spec = LoadBatchFile(batch_file);
  EXPECT_TRUE(spec.ok());
  std::set<std::string> ids;
  for (const auto& p : SelectShard(ExpandBatch(*spec), Shard{0, 1})) ids.insert(p.RunId());
  return ids;
}

TEST(BatchCommand, GivenTheSameBatchRunTwiceAndWithOneOrTwoJobsThenTheResultTablesAreIdentical) {
  const std::string dir = TempDir("cli_repeat");
  const auto a = Hexsim("batch " + DataFile("tiny.yaml") + " --jobs 2 --out " + dir + "/a", dir);
  ASSERT_EQ(a.exit_code, 0) << a.err;
  const auto b = Hexsim("batch " + DataFile("tiny.yaml") + " --jobs 2 --out " + dir + "/b", dir);
  ASSERT_EQ(b.exit_code, 0) << b.err;
  const auto c = Hexsim("batch " + DataFile("tiny.yaml") + " --jobs 1 --out " + dir + "/c", dir);
  ASSERT_EQ(c.exit_code, 0) << c.err;
  const auto ta = ComparableTable(dir + "/a/results.sqlite");
  ASSERT_EQ(ta.size(), ExpectedIds(DataFile("tiny.yaml")).size());
  EXPECT_EQ(ta, ComparableTable(dir + "/b/results.sqlite"));
  EXPECT_EQ(ta, ComparableTable(dir + "/c/results.sqlite"));
  // Each run left its summary, and the runs really flew: 3 s each, seeds differ.
  for (const auto& id : ExpectedIds(DataFile("tiny.yaml"))) {
    EXPECT_TRUE(fs::exists(fmt::format("{}/a/runs/{}/summary.json", dir, id))) << id;
  }
  auto rows = ResultsDb::Open(dir + "/a/results.sqlite", false)->ReadAll();
  std::set<double> energies;
  for (const auto& r : *rows) {
    EXPECT_NEAR(*r.metrics.at("flown_s"), 3.0, 0.011) << r.run_id;  // one log tick
    energies.insert(*r.metrics.at("energy_Wh"));
  }
  EXPECT_GT(energies.size(), 1u);
  // Without --resume an existing result is not overwritten.
  const auto again = Hexsim("batch " + DataFile("tiny.yaml") + " --out " + dir + "/a", dir);
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_NE(again.err.find("--resume"), std::string::npos) << again.err;
}

TEST(BatchCommand, GivenABatchKilledMidwayWhenResumedThenEveryRunIsPresentExactlyOnceAndMatchesAnUnbrokenRun) {
  const std::string dir = TempDir("cli_kill");
  const std::string batch = DataFile("kill.yaml");
  const std::string out = dir + "/killed";
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    setpgid(0, 0);  // its own process group, so the kill takes the workers too
    const int devnull = open("/dev/null", O_WRONLY);
    dup2(devnull, 1);
    dup2(devnull, 2);
    execl(HEXSIM_EXE, HEXSIM_EXE, "batch", batch.c_str(), "--jobs", "2", "--out", out.c_str(), (char*)nullptr);
    _exit(127);
  }
  setpgid(pid, pid);
  const size_t total = ExpectedIds(batch).size();
  int64_t seen = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (std::chrono::steady_clock::now() < deadline) {
    if (fs::exists(out + "/results.sqlite")) {
      auto db = ResultsDb::Open(out + "/results.sqlite", false);
      if (db.ok()) {
        auto n = db->Count();
        if (n.ok()) seen = *n;
      }
    }
    if (seen >= 3) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  kill(-pid, SIGKILL);
  int st = 0;
  waitpid(pid, &st, 0);
  ASSERT_TRUE(WIFSIGNALED(st)) << "the batch finished before it could be killed";
  const int64_t after_kill = *ResultsDb::Open(out + "/results.sqlite", false)->Count();
  ASSERT_GE(after_kill, 3);
  ASSERT_LT(static_cast<size_t>(after_kill), total);

  const auto resumed = Hexsim("batch " + batch + " --jobs 2 --resume --out " + out, dir);
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  auto rows = ResultsDb::Open(out + "/results.sqlite", false)->ReadAll();
  ASSERT_TRUE(rows.ok());
  std::multiset<std::string> ids;
  for (const auto& r : *rows) ids.insert(r.run_id);
  EXPECT_EQ(ids.size(), total);
  EXPECT_EQ(std::set<std::string>(ids.begin(), ids.end()), ExpectedIds(batch));
  // Nothing lost or altered: the same table as a batch that was never interrupted.
  const auto clean = Hexsim("batch " + batch + " --jobs 2 --out " + dir + "/clean", dir);
  ASSERT_EQ(clean.exit_code, 0) << clean.err;
  EXPECT_EQ(ComparableTable(out + "/results.sqlite"), ComparableTable(dir + "/clean/results.sqlite"));
}

TEST(BatchCommand, GivenShardsRunSeparatelyWhenMergedThenTheTableEqualsTheWholeBatch) {
  const std::string dir = TempDir("cli_shards");
  const std::string batch = DataFile("tiny.yaml");
  std::string shard_dirs;
  for (int i = 0; i < 3; ++i) {
    const std::string sd = dir + "/shard_" + std::to_string(i);
    const auto r = Hexsim(fmt::format("batch {} --jobs 1 --shard {}/3 --out {}", batch, i, sd), dir);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    shard_dirs += " " + sd;
  }
  // Shard 0 listed twice: merging deduplicates on run_id.
  const auto m = Hexsim("batch-merge " + dir + "/merged" + shard_dirs + " " + dir + "/shard_0", dir);
  ASSERT_EQ(m.exit_code, 0) << m.err;
  const auto whole = Hexsim("batch " + batch + " --jobs 2 --out " + dir + "/whole", dir);
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  EXPECT_EQ(ComparableTable(dir + "/merged/results.sqlite"), ComparableTable(dir + "/whole/results.sqlite"));
  EXPECT_FALSE(fs::exists(dir + "/shard_3"));

  const auto rep = Hexsim("batch-report " + dir + "/merged", dir);
  EXPECT_EQ(rep.exit_code, 0) << rep.err;
  EXPECT_NE(rep.out.find("cross_track_rms_m"), std::string::npos);
  EXPECT_TRUE(fs::exists(dir + "/merged/report.json"));
  EXPECT_TRUE(fs::exists(dir + "/merged/report.png"));
}

TEST(BatchCommand, GivenBadBatchFilesWhenRunThenExitIs2WithOneLineNamingTheFieldAndNothingIsWritten) {
  const std::string dir = TempDir("cli_bad");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"name: bad\nmissions: [square, no_such_mission]\n", "bad.yaml:2: missions[1]: no such mission"},
      {"missions: [square]\ngrid:\n  control.rate.roll.kp: []\n", "bad.yaml:3: grid.control.rate.roll.kp: empty sweep"},
      {"missions: [square\nseeds: [1]\n", "bad.yaml:"},
      {"missions: [square]\nset:\n  vehicle.no_such_field_kg: 3\n", "no_such_field_kg"},
  };
  for (const auto& [yaml, expected] : cases) {
    testing::WriteText(dir + "/bad.yaml", yaml);
    const auto r = Hexsim(fmt::format("batch {0}/bad.yaml --out {0}/out", dir), dir);
    EXPECT_EQ(r.exit_code, 2) << yaml << r.err;
    EXPECT_EQ(r.err.rfind("hexsim: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(expected), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(dir + "/out")) << yaml;
  }
  const auto shard = Hexsim("batch " + DataFile("tiny.yaml") + " --shard 4/4 --out " + dir + "/out", dir);
  EXPECT_EQ(shard.exit_code, 2);
  EXPECT_FALSE(fs::exists(dir + "/out"));
}

TEST(SlurmCluster, GivenARealSingleNodeSlurmWhenABatchRunsAsA4TaskArrayThenTheMergedResultsHoldEveryRunOnce) {
  const std::string dir = TempDir("slurm");
  const std::string cmd = "bash " + std::string(HEXSIM_SOURCE_DIR) + "/batch/test/slurm_cluster.sh " + HEXSIM_EXE + " " +
                          HEXSIM_SOURCE_DIR + " " + DataFile("tiny.yaml") + " >" + dir + "/log 2>&1";
  const int rc = std::system(cmd.c_str());
  const int code = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  const std::string log = testing::ReadText(dir + "/log");
  if (code == 77) GTEST_SKIP() << log;
  EXPECT_EQ(code, 0) << log;
  EXPECT_NE(log.find("PASS"), std::string::npos) << log;
}

}  // namespace
}  // namespace hexsim::batch
