// hexsim run MISSION [--vehicle V] [--world W] [--calibration NAME|FILE] [--seed N] [--duration S]
//                    [--set KEY=VALUE ...] --out DIR
#include <string>
#include <vector>

#include "cli_util.h"
#include "commands.h"
#include "hexsim/common/atomic_file.h"
#include "hexsim/experiments/point_runner.h"
#include "hexsim/sim/run_config.h"

namespace hexsim::app {

namespace {

struct RunArgs {
  sim::RunRequest request;
  std::string calibration = "none";
  std::string out;
};

Status RunCommand(const RunArgs& args, int* exit_code) {
  auto setup = sim::LoadRunSetup(args.request);
  if (!setup.ok()) return setup.status();
  OutputDirectory out;  // removed again unless committed: a bad calibration leaves nothing
  HEXSIM_RETURN_IF_ERROR(out.Open(args.out));
  auto flown = experiments::FlyPoint(std::move(*setup), args.calibration);
  if (!flown.ok()) return flown.status();
  const sim::RunOutput& result = *flown;
  HEXSIM_RETURN_IF_ERROR(experiments::WriteRunLog(result, out.path()));
  HEXSIM_RETURN_IF_ERROR(experiments::WriteRunSummary(result, out.path()));
  out.Commit();
  const auto& s = result.summary;
  // A run that did not finish says why on the same line: its figures are not a finished mission's.
  const std::string why = s.status == sim::RunStatus::kCompleted || s.reason.empty() ? "" : " (" + s.reason + ")";
  std::fprintf(stdout, "%s: %s%s in %.1f s, cross-track rms %.2f m, yaw error rms %.2f deg, energy %.2f Wh -> %s\n",
               s.mission.c_str(), sim::RunStatusName(s.status), why.c_str(), s.duration_s, s.cross_track_m.rms,
               s.yaw_error_deg.rms, s.energy_Wh, args.out.c_str());
  *exit_code = result.status.ok() ? 0 : Report(result.status);
  return Status::Ok();
}

}  // namespace

void AddRunCommand(CLI::App& app, int* exit_code) {
  auto args = std::make_shared<RunArgs>();
  CLI::App* cmd = app.add_subcommand("run", "Fly one closed-loop mission; writes log.csv, log.meta.json, summary.json");
  cmd->add_option("mission", args->request.mission, "Mission: a name under worlds/missions/ or a YAML path")->required();
  cmd->add_option("--vehicle", args->request.vehicle, "Vehicle name or YAML path")->capture_default_str();
  cmd->add_option("--world", args->request.world, "Environment name or YAML path")->capture_default_str();
  cmd->add_option("--calibration", args->calibration,
                  "Compass calibration: none|traditional|adaptive|adaptive-current|compassmot|px4-ls or a calib.yaml")
      ->capture_default_str();
  cmd->add_option("--estimator", args->request.estimator, "eskf|complementary|truth (default: sim.estimator = eskf)");
  cmd->add_option("--seed", args->request.seed, "Random seed")->capture_default_str();
  cmd->add_option("--duration", args->request.duration_s, "Stop after this many seconds (0: when the mission ends)");
  cmd->add_option("--set", args->request.sets, "Override a parameter, e.g. control.rate.roll.kp=0.12");
  cmd->add_flag("--allow-field-extrapolation", args->request.allow_field_extrapolation,
                "Allow a date outside the magnetic models' 2015.0-2030.0");
  cmd->add_option("--out", args->out, "Output directory")->required();
  cmd->callback([args, exit_code] {
    const Status s = RunCommand(*args, exit_code);
    if (!s.ok()) *exit_code = Report(s);
  });
}

}  // namespace hexsim::app
