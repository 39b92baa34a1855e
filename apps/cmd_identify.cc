// hexsim identify LOG.csv|LOG.bin|LOG.ulg [--frame auto|quad-x|...] [--base VEHICLE] --out vehicle.yaml
// Beside vehicle.yaml: identify.json (hexsim.identify/1), identify.html and its plots. An
// identification whose held-out residual is not below its base's exits 1, writes no vehicle and
// removes one an earlier run left at --out.
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "cli_util.h"
#include "commands.h"
#include "hexsim/common/atomic_file.h"
#include "hexsim/identify/identify.h"
#include "hexsim/logs/read_log.h"
#include "hexsim/reports/identify_report.h"

namespace hexsim::app {
namespace {

struct IdentifyArgs {
  std::string log, base, out;
  identify::IdentifyOptions options;
};

std::string DirOf(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? "." : path.substr(0, slash);
}

Status IdentifyCommand(const IdentifyArgs& a, int* exit_code) {
  if (const std::string why = a.options.IsValid(); !why.empty()) return Status::BadInput(why);
  std::vector<std::string> notes;
  auto log = logs::ReadAnyFlightLog(a.log, &notes);
  if (!log.ok()) return log.status();
  for (const auto& line : notes) std::printf("log: %s\n", line.c_str());
  auto base = identify::ChooseBaseVehicle(*log, a.base, a.options.frame, a.log, "give --frame or --base");
  if (!base.ok()) return base.status();
  identify::IdentifyOptions options = a.options;
  options.base_mass_known = !a.base.empty();  // a vehicle file given for this airframe
  auto r = identify::Identify(*log, base->params, options);
  if (!r.ok()) {
    // Identify names the log by its meta's source already; other errors get the path.
    const std::string source = log->meta.value("source", std::string());
    const bool named = !source.empty() && r.status().message().rfind(source + ":", 0) == 0;
    return named ? r.status() : r.status().WithContext(a.log);
  }
  const std::string dir = DirOf(a.out);
  HEXSIM_RETURN_IF_ERROR(EnsureDirectory(dir));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(dir + "/identify.json", identify::ToJson(*r).dump(2) + "\n"));
  HEXSIM_RETURN_IF_ERROR(reports::WriteIdentifyHtml(*r, dir));
  std::fputs(identify::Summary(*r).c_str(), stdout);
  // Last: the vehicle file means "done". One that improves nothing is not written (CONTRACTS exit 1:
  // the check failed), and a vehicle file an earlier run left at --out is removed.
  std::string outcome;
  HEXSIM_RETURN_IF_ERROR(identify::WriteIdentifiedVehicle(a.out, *base, *r, &outcome));
  if (!r->improves_on_base) {
    std::printf("identify: %s: %s %s\n", identify::ImprovementLine(*r).c_str(), a.out.c_str(), outcome.c_str());
    *exit_code = 1;
    return Status::Ok();
  }
  *exit_code = 0;
  return Status::Ok();
}

}  // namespace

void AddIdentifyCommand(CLI::App& app, int* exit_code) {
  auto a = std::make_shared<IdentifyArgs>();
  CLI::App* c = app.add_subcommand("identify", "Identify the log's vehicle (thrust curve, hover output, motor lag, "
                                               "drag, yaw torque, battery, IMU noise) and write a vehicle file");
  c->add_option("log", a->log, "FlightLog CSV (its .meta.json and stream files beside it), or an ArduPilot .bin / "
                               "PX4 .ulg (imported in memory)")->required();
  c->add_option("--frame", a->options.frame,
                "auto, or an ArduPilot motor table: quad-x|quad-plus|quad-v|quad-h|quad-plus-rev|quad-bf-x|quad-dji-x|"
                "quad-cw-x|quad-bf-x-rev|hex-x|hex-plus|hex-h|hex-dji-x|hex-cw-x|octo-x")
      ->capture_default_str();
  c->add_option("--base", a->base, "Vehicle for what the log cannot tell (default: the shipped one of the frame class)");
  c->add_option("--out", a->out, "Vehicle YAML to write (identify.json and identify.html go beside it)")->required();
  c->add_option("--seed", a->options.seed, "Bootstrap seed")->capture_default_str();
  c->add_option("--bootstrap", a->options.bootstrap_samples, "Block bootstrap resamples")->capture_default_str();
  c->callback([a, exit_code] {
    int code = 0;
    const Status s = IdentifyCommand(*a, &code);
    *exit_code = s.ok() ? code : Report(s);
  });
}

}  // namespace hexsim::app
