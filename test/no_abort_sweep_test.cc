// Every subcommand on inputs a user gets wrong: an empty file, a missing file, a directory, and a file
// of the wrong type (binary bytes where text is expected, text where a DataFlash log is expected).
// Each must end with exit 2 or 3 and exactly one line on stderr, never by a signal (CONTRACTS.md:
// exit codes; PROTOCOL: no command ever dies by a signal).
#include <sys/wait.h>

#include <filesystem>
#include <fstream>
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>

namespace {

namespace fs = std::filesystem;

// One way of getting the input wrong. `path` is what the command receives.
struct BadInput {
  std::string kind;
  fs::path path;
};

// A command line with one input slot, written as `{}`.
struct Case {
  std::string name;
  std::string args;
};

struct Outcome {
  bool signalled = false;
  int signal = 0;
  int code = -1;
  std::string err;
};

class NoAbortSweep : public ::testing::TestWithParam<Case> {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("hexsim_sweep_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "a_directory.yaml");
    std::ofstream(dir_ / "empty.yaml").close();
    std::string binary;
    for (int i = 0; i < 4096; ++i) binary.push_back(static_cast<char>((i * 37 + 11) & 0xff));
    std::ofstream(dir_ / "binary.yaml", std::ios::binary) << binary;
    std::ofstream(dir_ / "text.bin") << "t_s,mag_x_uT\n0,1\nthis is not a DataFlash log\n";
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  static std::vector<BadInput> Inputs() {
    return {{"empty", dir_ / "empty.yaml"},
            {"missing", dir_ / "no_such_file.yaml"},
            {"directory", dir_ / "a_directory.yaml"},
            {"binary", dir_ / "binary.yaml"},
            {"text as log", dir_ / "text.bin"}};
  }

  // Runs hexsim with `{}` replaced by `input`, output into a fresh directory; a command that runs
  // longer than 120 s is killed by `timeout` (a signal, so the test fails).
  static Outcome Run(const std::string& args, const fs::path& input) {
    std::string a = args;
    const size_t slot = a.find("{}");
    a.replace(slot, 2, "'" + input.string() + "'");
    const size_t out_slot = a.find("{out}");
    if (out_slot != std::string::npos) {
      fs::remove_all(dir_ / "out");
      a.replace(out_slot, 5, (dir_ / "out").string());
    }
    const fs::path err_file = dir_ / "stderr.txt";
    const std::string cmd = "timeout -s KILL 120 " + std::string(HEXSIM_BINARY) + " " + a + " >/dev/null 2>" +
                            err_file.string() + "; echo $? > " + (dir_ / "rc.txt").string();
    (void)std::system(cmd.c_str());
    std::ifstream rc_in(dir_ / "rc.txt");
    int rc = -1;
    rc_in >> rc;
    Outcome o;
    // The shell reports a child killed by signal s as 128 + s.
    o.signalled = rc > 128;
    o.signal = rc > 128 ? rc - 128 : 0;
    o.code = rc;
    std::ifstream e(err_file);
    std::stringstream ss;
    ss << e.rdbuf();
    o.err = ss.str();
    return o;
  }

  static fs::path dir_;
};

fs::path NoAbortSweep::dir_;

// Readable test names and failure messages: a case prints as its name.
void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

int Lines(const std::string& s) {
  int n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

TEST_P(NoAbortSweep, GivenBadInputWhenCommandRunsThenExit2Or3WithOneLineNeverASignal) {
  const Case& c = GetParam();
  for (const BadInput& in : Inputs()) {
    // When
    const Outcome o = Run(c.args, in.path);
    // Then
    SCOPED_TRACE(c.name + " on " + in.kind + " input: hexsim " + c.args);
    EXPECT_FALSE(o.signalled) << "killed by signal " << o.signal << "; stderr: " << o.err;
    EXPECT_TRUE(o.code == 2 || o.code == 3) << "exit " << o.code << "; stderr: " << o.err;
    EXPECT_EQ(Lines(o.err), 1) << o.err;
    EXPECT_EQ(o.err.rfind("hexsim: ", 0), 0U) << o.err;
  }
}

// Each subcommand, with its file inputs in turn. Options that pick a vehicle, world, mission or
// calibration file take names or paths; they are swept where the command reads them first.
const Case kCases[] = {
    {"run_mission", "run {} --duration 1 --out {out}"},
    {"run_vehicle", "run square --vehicle {} --duration 1 --out {out}"},
    {"run_world", "run square --world {} --duration 1 --out {out}"},
    {"run_calibration", "run square --calibration {} --duration 1 --out {out}"},
    {"turntable_vehicle", "turntable --vehicle {} --out {out}"},
    {"turntable_world", "turntable --world {} --out {out}"},
    {"calibrate_traditional", "calibrate {} --method traditional --out {out}/c.yaml"},
    {"calibrate_adaptive", "calibrate {} --method adaptive --out {out}/c.yaml"},
    {"calibrate_none", "calibrate {} --method none --out {out}/c.yaml"},
    {"heading_error", "heading-error --calib {}"},
    {"heading_error_vehicle", "heading-error --vehicle {}"},
    {"compare_mission", "compare {} --seeds 1 --duration 1 --out {out}"},
    {"compare_vehicle", "compare --vehicle {} --seeds 1 --duration 1 --out {out}"},
    {"batch", "batch {} --out {out}"},
    {"batch_report", "batch-report {}"},
    {"batch_merge", "batch-merge {out} {}"},
    {"import", "import {} --out {out}/log.csv"},
    {"import_info", "import --info {}"},
    {"gap_diagnose_real", "gap diagnose --real {} --sim quad_x --out {out}"},
    {"identify", "identify {} --out {out}/v.yaml"},
    {"plot", "plot {} --out {out}"},
    {"step_vehicle", "step --axis roll --size 5 --vehicle {} --out {out}"},
    {"freqresp_vehicle", "freqresp --axis roll --vehicle {} --out {out}"},
    {"disturb_vehicle", "disturb --gust 1,0,0 --vehicle {} --out {out}"},
};

// Good input that once aborted: `calibrate --method none` on turntable samples died with SIGABRT
// (rc 134, issue 19). Every method on good samples ends with an exit code, never a signal.
TEST(NoAbortGoodInput, GivenTurntableSamplesWhenEachMethodCalibratesThenNoneDiesByASignal) {
  // Given
  const fs::path d = fs::temp_directory_path() / ("hexsim_sweep_good_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  const std::string hexsim = HEXSIM_BINARY;
  ASSERT_EQ(std::system((hexsim + " turntable --out " + (d / "tt").string() + " >/dev/null").c_str()), 0);
  for (const char* method : {"none", "traditional", "adaptive", "adaptive-current", "compassmot", "px4-ls"}) {
    // When
    const std::string cmd = hexsim + " calibrate " + (d / "tt" / "samples.csv").string() + " --method " + method +
                            " --out " + (d / method).string() + ".yaml >/dev/null 2>&1; echo $? > " +
                            (d / "rc.txt").string();
    (void)std::system(cmd.c_str());
    int rc = -1;
    std::ifstream(d / "rc.txt") >> rc;
    // Then: 0 (accepted) or 1 (rejected by its gate), never a signal
    EXPECT_TRUE(rc == 0 || rc == 1) << method << ": exit " << rc << (rc > 128 ? " (killed by a signal)" : "");
  }
  fs::remove_all(d);
}

INSTANTIATE_TEST_SUITE_P(EveryCommand, NoAbortSweep, ::testing::ValuesIn(kCases),
                         [](const ::testing::TestParamInfo<Case>& info) { return info.param.name; });

}  // namespace
