// Helpers shared by the batch tests: temporary directories, running the hexsim executable, reading
// a results table without the columns that may differ between identical batches.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hexsim/batch/results_db.h"

namespace hexsim::batch::testing {

inline std::string TempDir(const std::string& name) {
  const auto base = std::filesystem::temp_directory_path() /
                    ("hexsim_batch_test_" + std::to_string(getpid()) + "_" + name);
  std::filesystem::remove_all(base);
  std::filesystem::create_directories(base);
  return base.string();
}

inline std::string DataFile(const std::string& name) {
  return std::string(HEXSIM_SOURCE_DIR) + "/batch/test/data/" + name;
}

inline void WriteText(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

inline std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

struct CommandResult {
  int exit_code = -1;
  std::string out, err;
};

// Runs `hexsim ARGS` (ARGS already shell-quoted where needed) and captures its output.
inline CommandResult Hexsim(const std::string& args, const std::string& scratch) {
  const std::string out = scratch + "/cmd.stdout", err = scratch + "/cmd.stderr";
  const std::string cmd = std::string(HEXSIM_EXE) + " " + args + " >" + out + " 2>" + err;
  const int rc = std::system(cmd.c_str());
  CommandResult r;
  r.exit_code = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  r.out = ReadText(out);
  r.err = ReadText(err);
  return r;
}

// One line per run: every column except wall_s, host and finished_at (CONTRACTS: "identical").
inline std::vector<std::string> ComparableTable(const std::string& db_path) {
  auto db = ResultsDb::Open(db_path, /*create=*/false);
  EXPECT_TRUE(db.ok()) << db.status().message();
  if (!db.ok()) return {};
  auto rows = db->ReadAll();
  EXPECT_TRUE(rows.ok());
  std::vector<std::string> out;
  for (const auto& r : *rows) {
    std::string line = r.run_id + "|" + r.params_json + "|" + r.mission + "|" + r.vehicle + "|" + r.world + "|" +
                       r.calibration + "|" + r.estimator + "|" + std::to_string(r.seed) + "|" + r.status + "|" +
                       r.reason + "|" + r.waypoints_json + "|" + r.summary_json + "|" + r.version;
    for (const auto& [k, v] : r.metrics) {
      std::ostringstream ss;
      ss.precision(17);
      ss << "|" << k << "=";
      if (v) {
        ss << *v;
      } else {
        ss << "NULL";
      }
      line += ss.str();
    }
    out.push_back(line);
  }
  return out;
}

}  // namespace hexsim::batch::testing
