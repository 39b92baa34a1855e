// hexsim plot LOG.csv [LOG2.csv ...] --out DIR: off-screen figures of FlightLogs (simulated or
// imported). One log: the standard set in DIR. Several: each log's standard set in DIR/<name>/ and
// overlays of their tracks and yaw errors in DIR.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "cli_util.h"
#include "commands.h"
#include "hexsim/common/atomic_file.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/render/figures.h"
#include "hexsim/render/paper_figures.h"

namespace hexsim::app {

namespace {

struct PlotArgs {
  std::vector<std::string> logs;
  std::string out;
};

// A short, unique, file-system-safe name per log: its stem, or "<parent>_<stem>" when stems repeat
// (e.g. several runs' log.csv), then an index if still not unique.
std::vector<std::string> LogNames(const std::vector<std::string>& paths) {
  namespace fs = std::filesystem;
  std::vector<std::string> names;
  names.reserve(paths.size());
  for (const auto& p : paths) names.push_back(fs::path(p).stem().string());
  auto unique = [&] {
    for (size_t i = 0; i < names.size(); ++i) {
      if (std::count(names.begin(), names.end(), names[i]) > 1) return false;
    }
    return true;
  };
  if (!unique()) {
    for (size_t i = 0; i < names.size(); ++i) {
      const fs::path abs = fs::absolute(paths[i]).lexically_normal();
      const std::string parent = abs.parent_path().filename().string();
      if (!parent.empty()) names[i] = parent + "_" + names[i];
    }
  }
  if (!unique()) {
    for (size_t i = 0; i < names.size(); ++i) names[i] = std::to_string(i + 1) + "_" + names[i];
  }
  return names;
}

Status PlotCommand(const PlotArgs& args) {
  // Read and validate every log before anything is written.
  std::vector<logs::FlightLog> logs;
  for (const auto& path : args.logs) {
    auto log = logs::ReadFlightLog(path);
    if (!log.ok()) return log.status();
    if (log->rows() == 0) return Status::BadInput(path + ": the log has no rows");
    logs.push_back(std::move(*log));
  }
  OutputDirectory out;
  HEXSIM_RETURN_IF_ERROR(out.Open(args.out));
  std::vector<std::string> written;
  if (logs.size() == 1) {
    HEXSIM_RETURN_IF_ERROR(render::RenderStandardFigures(logs[0], out.path(), &written));
  } else {
    const std::vector<std::string> names = LogNames(args.logs);
    std::vector<const logs::FlightLog*> ptrs;
    for (size_t i = 0; i < logs.size(); ++i) {
      HEXSIM_RETURN_IF_ERROR(render::RenderStandardFigures(logs[i], out.File(names[i]), &written));
      ptrs.push_back(&logs[i]);
    }
    HEXSIM_RETURN_IF_ERROR(render::RenderLogOverlays(ptrs, names, out.path(), &written));
  }
  out.Commit();
  for (const auto& w : written) std::printf("%s\n", w.c_str());
  std::fprintf(stderr, "plot: %zu figures -> %s\n", written.size(), args.out.c_str());
  return Status::Ok();
}

}  // namespace

void AddPlotCommand(CLI::App& app, int* exit_code) {
  auto args = std::make_shared<PlotArgs>();
  CLI::App* cmd = app.add_subcommand("plot", "Render PNG figures of one or more FlightLogs (headless)");
  cmd->add_option("logs", args->logs, "FlightLog CSV files (several: overlays too)")->required();
  cmd->add_option("--out", args->out, "Output directory")->required();
  cmd->callback([args, exit_code] { *exit_code = Report(PlotCommand(*args)); });
}

}  // namespace hexsim::app
