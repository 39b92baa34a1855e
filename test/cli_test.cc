// The hexsim command line as a user meets it: exit codes, one-line errors naming file and field,
// nothing half-written, determinism.
#include <fcntl.h>
#include <signal.h>  // NOLINT(modernize-deprecated-headers): kill is POSIX
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace {

namespace fs = std::filesystem;

struct CmdResult {
  int code = -1;
  std::string err;
  std::string out;
};

CmdResult Hexsim(const std::string& args) {
  const fs::path dir = fs::temp_directory_path() / ("hexsim_cli_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string err_file = (dir / "stderr.txt").string(), out_file = (dir / "stdout.txt").string();
  const std::string cmd = std::string(HEXSIM_BINARY) + " " + args + " >" + out_file + " 2>" + err_file;
  const int raw = std::system(cmd.c_str());
  CmdResult r;
  r.code = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  std::ifstream e(err_file), o(out_file);
  std::stringstream es, os;
  es << e.rdbuf();
  os << o.rdbuf();
  r.err = es.str();
  r.out = os.str();
  return r;
}

fs::path TempDir(const std::string& name) {
  fs::path p = fs::temp_directory_path() / ("hexsim_cli_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

void Write(const fs::path& p, const std::string& text) {
  std::ofstream f(p);
  f << text;
}

int Lines(const std::string& s) {
  int n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

std::string Slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

TEST(Cli, GivenMalformedYamlMissionWhenRunThenOneLineNamesFileAndExit2AndNoOutput) {
  const fs::path d = TempDir("malformed");
  Write(d / "bad.yaml", "items: [\n  - {type: takeoff, alt_m: 10\n");
  const fs::path out = d / "out";
  const CmdResult r = Hexsim("fly " + (d / "bad.yaml").string());
  // (mission is a positional of `run`)
  const CmdResult r2 = Hexsim("run " + (d / "bad.yaml").string() + " --out " + out.string());
  EXPECT_EQ(r2.code, 2);
  EXPECT_EQ(Lines(r2.err), 1) << r2.err;
  EXPECT_NE(r2.err.find("bad.yaml:"), std::string::npos) << r2.err;
  EXPECT_FALSE(fs::exists(out));
  EXPECT_EQ(r.code, 2);  // an unknown subcommand is bad usage too
}

TEST(Cli, GivenNegativeMassWhenRunThenErrorNamesFieldAndLine) {
  const fs::path d = TempDir("mass");
  std::ifstream in(std::string(HEXSIM_SOURCE_DIR) + "/worlds/vehicles/default_hex.yaml");
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  const size_t pos = text.find("mass_kg:");
  ASSERT_NE(pos, std::string::npos);
  const size_t eol = text.find('\n', pos);
  text.replace(pos, eol - pos, "mass_kg: -2.0");
  Write(d / "neg.yaml", text);
  const fs::path out = d / "out";
  const CmdResult r = Hexsim("run square --vehicle " + (d / "neg.yaml").string() + " --out " + out.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(Lines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("neg.yaml:"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("mass_kg: must be > 0"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

TEST(Cli, GivenUnknownKeyOrMissingFileWhenRunThenExit2) {
  const fs::path d = TempDir("unknown");
  Write(d / "m.yaml", "speed_mps: 3\ncolour: red\nitems:\n  - {type: takeoff, alt_m: 5}\n  - {type: land}\n");
  CmdResult r = Hexsim("run " + (d / "m.yaml").string() + " --out " + (d / "o").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("m.yaml:2: colour: unknown key"), std::string::npos) << r.err;
  r = Hexsim("run " + (d / "nope.yaml").string() + " --out " + (d / "o").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("nope.yaml"), std::string::npos) << r.err;
  r = Hexsim("run square --set control.rate.roll.kq=1 --out " + (d / "o").string());
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_FALSE(fs::exists(d / "o"));
}

TEST(Cli, GivenANegativeJobCountWhenDiagnosingThenExit2NamingTheFlag) {
  const fs::path d = TempDir("gapjobs");
  const CmdResult r = Hexsim("gap diagnose --real " + std::string(HEXSIM_SOURCE_DIR) +
                             "/data/real/ardupilot_copter_log171.bin --jobs -1 --out " + (d / "o").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(Lines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("--jobs"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(d / "o"));
}

TEST(Cli, GivenSameSeedWhenRunTwiceThenLogsAreByteIdentical) {
  const fs::path d = TempDir("determinism");
  const std::string args = "run square --vehicle default_hex --duration 20 --seed 42";
  ASSERT_EQ(Hexsim(args + " --out " + (d / "a").string()).code, 0);
  ASSERT_EQ(Hexsim(args + " --out " + (d / "b").string()).code, 0);
  const std::string a = Slurp(d / "a" / "log.csv"), b = Slurp(d / "b" / "log.csv");
  EXPECT_GT(a.size(), 10000u);
  EXPECT_TRUE(a == b);
  ASSERT_EQ(Hexsim("run square --vehicle default_hex --duration 20 --seed 43 --out " + (d / "c").string()).code, 0);
  EXPECT_FALSE(a == Slurp(d / "c" / "log.csv"));
}

TEST(Cli, GivenBadSampleFilesWhenCalibratingThenExit2WithReason) {
  const fs::path d = TempDir("badsamples");
  Write(d / "empty.csv", "");
  CmdResult r = Hexsim("calibrate " + (d / "empty.csv").string() + " --method traditional --out " + (d / "c.yaml").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(Lines(r.err), 1) << r.err;
  // One plane only.
  ASSERT_EQ(Hexsim("turntable --planes xy --control 0,300 --step-deg 20 --out " + (d / "tt").string()).code, 0);
  r = Hexsim("calibrate " + (d / "tt" / "samples.csv").string() + " --method adaptive --out " + (d / "c.yaml").string());
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("plane"), std::string::npos) << r.err;
  // A NaN reading.
  std::string text = Slurp(d / "tt" / "samples.csv");
  const size_t row2 = text.find('\n', text.find('\n') + 1) + 1;
  const size_t comma = text.find(",mag", 0);
  (void)comma;
  std::string line = text.substr(row2, text.find('\n', row2) - row2);
  std::string bad = line;
  const size_t c8 = [&] {
    size_t p = 0;
    for (int i = 0; i < 8; ++i) p = bad.find(',', p) + 1;
    return p;
  }();
  bad.replace(c8, bad.find(',', c8) - c8, "nan");
  text.replace(row2, line.size(), bad);
  Write(d / "nan.csv", text);
  r = Hexsim("calibrate " + (d / "nan.csv").string() + " --method traditional --out " + (d / "c.yaml").string());
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("nan.csv:3"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(d / "c.yaml"));
}

// `compare` with a calib.yaml path among its calibrations used to fly every run and then die with
// "unexpected error: map::at" (the runs were filed under the path, their summaries under its stem).
// The run is filed, grouped and shown under the file's stem; naming a calibration twice is bad input.
TEST(Cli, GivenACalibrationFileAmongCompareCalibrationsWhenComparedThenItFinishesUnderTheFilesStem) {
  const fs::path d = TempDir("compare_file");
  CmdResult r = Hexsim("turntable --vehicle paper_hex --out " + (d / "tt").string());
  ASSERT_EQ(r.code, 0) << r.err;
  r = Hexsim("calibrate " + (d / "tt" / "samples.csv").string() + " --method adaptive --out " +
             (d / "tt" / "mine.yaml").string());
  ASSERT_EQ(r.code, 0) << r.err;
  r = Hexsim("compare square --vehicle paper_hex --world changchun --seeds 1 --duration 5 --no-report --calibrations " +
             (d / "tt" / "mine.yaml").string() + ",none --out " + (d / "cmp").string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(d / "cmp" / "mine" / "seed_1" / "summary.json"));
  const auto cmp = nlohmann::json::parse(Slurp(d / "cmp" / "comparison.json"));
  ASSERT_EQ(cmp["groups"].size(), 2u);
  EXPECT_EQ(cmp["groups"][0]["calibration"], "mine");
  EXPECT_EQ(cmp["groups"][1]["calibration"], "none");

  r = Hexsim("compare square --seeds 1 --calibrations none,adaptive,none --out " + (d / "twice").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(Lines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("--calibrations: 'none' listed twice"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(d / "twice"));
}

// A batch of 10^8 seeds threw std::bad_alloc while its seed list was filled, also with --list.
TEST(Cli, GivenABatchOfAHundredMillionSeedsWhenListedOrRunThenOneLineAndExit2) {
  const fs::path d = TempDir("batch_huge");
  Write(d / "huge.yaml", "missions: [square]\nseeds: {first: 1, count: 100000000}\n");
  for (const std::string& tail : {std::string(" --list"), " --out " + (d / "out").string()}) {
    const CmdResult r = Hexsim("batch " + (d / "huge.yaml").string() + tail);
    EXPECT_EQ(r.code, 2) << tail;
    EXPECT_EQ(Lines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find("huge.yaml:2: seeds.count:"), std::string::npos) << r.err;
    EXPECT_EQ(r.out, "");
  }
  EXPECT_FALSE(fs::exists(d / "out"));
}

// Ctrl-C during a batch (CONTRACTS: exit 130): the running run finishes and is recorded, nothing else
// starts, no SQLite -wal/-shm file or empty run folder is left, stderr says how to --resume, and
// --resume finishes the batch. It used to exit 130 silently, leaving both.
TEST(Cli, GivenABatchInterruptedOnceWhenItStopsThenExit130WithAResumeLineAndResumeFinishesIt) {
  const fs::path d = TempDir("batch_interrupt");
  Write(d / "b.yaml", "missions: [square]\nvehicles: [default_hex]\nseeds: {first: 1, count: 6}\n");
  const fs::path out = d / "out", err = d / "stderr.txt";
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const int fd = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    dup2(fd, STDERR_FILENO);
    const int null_fd = ::open("/dev/null", O_WRONLY);
    dup2(null_fd, STDOUT_FILENO);
    const std::string file = (d / "b.yaml").string(), out_s = out.string();
    execl(HEXSIM_BINARY, HEXSIM_BINARY, "batch", file.c_str(), "--jobs", "1", "--out", out_s.c_str(),
          static_cast<char*>(nullptr));
    std::_Exit(127);
  }
  // Interrupt once the first run has left its summary (the second is then running).
  auto summaries = [&] {
    int n = 0;
    std::error_code ec;
    if (!fs::is_directory(out / "runs", ec)) return 0;
    for (const auto& e : fs::directory_iterator(out / "runs")) n += fs::exists(e.path() / "summary.json");
    return n;
  };
  for (int i = 0; i < 600 && summaries() == 0; ++i) usleep(50000);
  ASSERT_GT(summaries(), 0) << Slurp(err);
  kill(pid, SIGINT);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status)) << "died by a signal";
  EXPECT_EQ(WEXITSTATUS(status), 130) << Slurp(err);
  const std::string e = Slurp(err);
  EXPECT_NE(e.find("interrupted"), std::string::npos) << e;
  EXPECT_NE(e.find("--out " + out.string() + " --resume"), std::string::npos) << e;
  EXPECT_FALSE(fs::exists(out / "results.sqlite-wal"));
  EXPECT_FALSE(fs::exists(out / "results.sqlite-shm"));
  int folders = 0;
  for (const auto& entry : fs::directory_iterator(out / "runs")) {
    ++folders;
    EXPECT_TRUE(fs::exists(entry.path() / "summary.json")) << entry.path() << ": a partial run folder";
  }
  EXPECT_GE(folders, 1);
  EXPECT_LT(folders, 6) << "the batch ran to its end: nothing was interrupted";

  const CmdResult resumed = Hexsim("batch " + (d / "b.yaml").string() + " --jobs 1 --resume --out " + out.string());
  EXPECT_EQ(resumed.code, 0) << resumed.err;
  EXPECT_NE(resumed.out.find("6/6 runs recorded"), std::string::npos) << resumed.out;
}

// A bad --set value was blamed on the vehicle file's line 1 (the replaced node has no line of its own).
TEST(Cli, GivenABadSetValueWhenRunThenTheErrorNamesTheSetArgument) {
  const fs::path d = TempDir("bad_set");
  for (const std::string& set : {std::string("vehicle.mass_kg=abc"), std::string("control.rate.roll.kp=abc"),
                                 std::string("world.wind.turbulence_std_mps=-1")}) {
    const CmdResult r = Hexsim("run square --set " + set + " --out " + (d / "out").string());
    EXPECT_EQ(r.code, 2) << set;
    EXPECT_EQ(Lines(r.err), 1) << r.err;
    EXPECT_EQ(r.err.rfind("hexsim: --set " + set + ": ", 0), 0u) << r.err;
  }
  EXPECT_FALSE(fs::exists(d / "out"));
}

}  // namespace
