// hexsim identify LOG.csv [--frame auto|quad-x|...] [--base VEHICLE] --out vehicle.yaml
// Beside vehicle.yaml: identify.json (hexsim.identify/1), identify.html and its plots.
#include <cstdio>
#include <memory>
#include <string>

#include "cli_util.h"
#include "commands.h"
#include "hexsim/common/atomic_file.h"
#include "hexsim/common/paths.h"
#include "hexsim/identify/identify.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/reports/identify_report.h"
#include "hexsim/vehicle/vehicle_io.h"
#include "hexsim/vehicle/vehicle_params.h"

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

Status IdentifyCommand(const IdentifyArgs& a) {
  if (const std::string why = a.options.IsValid(); !why.empty()) return Status::BadInput(why);
  auto log = logs::ReadFlightLog(a.log);
  if (!log.ok()) return log.status();
  std::string base_name = a.base;
  if (base_name.empty()) {
    std::string source;
    const std::string frame = a.options.frame != "auto" ? a.options.frame : identify::FrameOfLog(*log, &source);
    base_name = identify::DefaultBaseFor(frame);
    if (base_name.empty()) {
      return Status::BadInput(a.log + ": frame: not determined or no shipped vehicle for '" + frame +
                              "' (give --frame or --base)");
    }
  }
  auto path = ResolveWorldFile("vehicles", base_name);
  if (!path.ok()) return path.status();
  auto text = ReadFile(*path);
  if (!text.ok()) return text.status();
  auto base = vehicle::LoadVehicleFile(*path);
  if (!base.ok()) return base.status();
  auto r = identify::Identify(*log, *base, a.options);
  if (!r.ok()) return r.status().WithContext(a.log);
  auto yaml = identify::IdentifiedVehicleYaml(*text, *base, *r);
  if (!yaml.ok()) return yaml.status();
  const std::string dir = DirOf(a.out);
  HEXSIM_RETURN_IF_ERROR(EnsureDirectory(dir));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(dir + "/identify.json", identify::ToJson(*r).dump(2) + "\n"));
  HEXSIM_RETURN_IF_ERROR(reports::WriteIdentifyHtml(*r, dir));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(a.out, *yaml));  // last: the vehicle file means "done"
  std::fputs(identify::Summary(*r).c_str(), stdout);
  return Status::Ok();
}

}  // namespace

void AddIdentifyCommand(CLI::App& app, int* exit_code) {
  auto a = std::make_shared<IdentifyArgs>();
  CLI::App* c = app.add_subcommand("identify", "Identify the log's vehicle (thrust curve, hover output, motor lag, "
                                               "drag, yaw torque, battery, IMU noise) and write a vehicle file");
  c->add_option("log", a->log, "FlightLog CSV (its .meta.json and stream files beside it)")->required();
  c->add_option("--frame", a->options.frame,
                "auto, or an ArduPilot motor table: quad-x|quad-plus|quad-v|quad-h|quad-plus-rev|quad-bf-x|quad-dji-x|"
                "quad-cw-x|quad-bf-x-rev|hex-x|hex-plus|hex-h|hex-dji-x|hex-cw-x|octo-x")
      ->capture_default_str();
  c->add_option("--base", a->base, "Vehicle for what the log cannot tell (default: the shipped one of the frame class)");
  c->add_option("--out", a->out, "Vehicle YAML to write (identify.json and identify.html go beside it)")->required();
  c->add_option("--seed", a->options.seed, "Bootstrap seed")->capture_default_str();
  c->add_option("--bootstrap", a->options.bootstrap_samples, "Block bootstrap resamples")->capture_default_str();
  c->callback([a, exit_code] {
    const Status s = IdentifyCommand(*a);
    *exit_code = s.ok() ? 0 : Report(s);
  });
}

}  // namespace hexsim::app
