// hexsim gap diagnose --real LOG.csv [--sim VEHICLE_OR_CONFIG] --out DIR [--from S --to S]
// hexsim gap selftest [--profile real|ideal] [--trials N] [--seed S] [--jobs N] [--json FILE]
#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>
#include <unistd.h>

#include "cli_util.h"
#include "commands.h"
#include "hexsim/batch/pool.h"
#include "hexsim/common/atomic_file.h"
#include "hexsim/common/paths.h"
#include "hexsim/gap/diagnose.h"
#include "hexsim/identify/identify.h"
#include "hexsim/reports/gap_report.h"
#include "hexsim/gap/selftest.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/vehicle/vehicle_io.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::app {
namespace {

struct DiagnoseArgs {
  std::string real, sim_config, out;
  uint64_t seed = 1;
  double from_s = 0.0, to_s = 0.0;
};

// The vehicle to diagnose against, and what the report says about it (CONTRACTS "Second wave":
// --sim is optional). Without --sim the log's vehicle is identified on the even time blocks and the
// diagnosis runs on the odd ones; with --sim the identified vehicle is compared with the given one.
struct DiagnosisVehicle {
  vehicle::VehicleParams params;
  std::string yaml_text, stem;
  logs::FlightLog log;  // the log the diagnosis reads (held-out blocks only without --sim)
  nlohmann::json json = nlohmann::json::object();
  std::vector<std::string> lines;
};

Result<DiagnosisVehicle> ChooseVehicle(const DiagnoseArgs& a, const logs::FlightLog& log) {
  DiagnosisVehicle d;
  d.log = log;
  std::string base_name = a.sim_config;
  if (a.sim_config.empty()) {
    std::string source;
    base_name = identify::DefaultBaseFor(identify::FrameOfLog(log, &source));
    if (base_name.empty()) return Status::BadInput(a.real + ": frame: not determined (" + source + "); give --sim VEHICLE");
  }
  auto path = ResolveWorldFile("vehicles", base_name);
  if (!path.ok()) return path.status();
  auto text = ReadFile(*path);
  if (!text.ok()) return text.status();
  auto vehicle = vehicle::LoadVehicleFile(*path);
  if (!vehicle.ok()) return vehicle.status();
  if (!a.sim_config.empty()) {
    d.params = *vehicle;
    d.yaml_text = *text;
    d.stem = FileStem(*path);
    auto r = identify::Identify(log, *vehicle);
    d.json["mode"] = "given (--sim)";
    if (r.ok()) {
      d.json["distance_from_identified"] = identify::DistanceFromVehicle(*r, *vehicle, &d.lines);
    } else {
      d.json["distance_from_identified"] = "not computed: " + r.status().message();
    }
    return d;
  }
  identify::IdentifyOptions io;
  for (int b = 0; b < io.blocks; b += 2) io.fit_blocks.push_back(b);
  auto r = identify::Identify(log, *vehicle, io);
  if (!r.ok()) return r.status().WithContext("gap diagnose without --sim identifies the vehicle first");
  d.params = identify::ApplyIdentified(*vehicle, *r);
  auto yaml = identify::IdentifiedVehicleYaml(*text, *vehicle, *r);
  if (!yaml.ok()) return yaml.status();
  d.yaml_text = *yaml;
  d.stem = "identified";
  d.log = identify::HeldOutLog(log, *r);
  d.json["mode"] = "identified (no --sim)";
  d.json["how"] = "vehicle identified from this log (base " + vehicle->name +
                  ") on the even time blocks of its flight windows; diagnosed on the odd (held-out) blocks only";
  d.json["identify"] = identify::ToJson(*r);
  d.lines.push_back("no --sim: the vehicle was identified from this log (base " + vehicle->name +
                    ") on the even time blocks; this diagnosis uses the odd (held-out) blocks only");
  return d;
}

Status DiagnoseCommand(const DiagnoseArgs& a) {
  auto log = logs::ReadFlightLog(a.real);
  if (!log.ok()) return log.status();
  if (log->rows() == 0) return Status::BadInput(a.real + ": no data rows");
  auto chosen = ChooseVehicle(a, *log);
  if (!chosen.ok()) return chosen.status();
  const vehicle::VehicleParams* vehicle = &chosen->params;
  const std::string* text = &chosen->yaml_text;
  gap::DiagnoseOptions opt;
  opt.seed = a.seed;
  if (a.from_s != 0.0 || a.to_s != 0.0) {
    if (!(a.to_s > a.from_s)) return Status::BadInput("--from/--to: --to must be after --from");
    opt.from_s = a.from_s;
    opt.to_s = a.to_s;
  }
  auto report = gap::Diagnose(chosen->log, *vehicle, opt);
  if (!report.ok()) return report.status().WithContext(a.real);
  report->log_name = a.real;
  auto updated = gap::UpdatedVehicleYaml(*text, *vehicle, *report);
  if (!updated.ok()) return updated.status();
  OutputDirectory out;
  HEXSIM_RETURN_IF_ERROR(out.Open(a.out));
  nlohmann::json gap_json = gap::ToJson(*report);
  gap_json["vehicle_source"] = chosen->json;
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("gap.json"), gap_json.dump(2) + "\n"));
  if (a.sim_config.empty()) HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("identified.yaml"), *text));
  HEXSIM_RETURN_IF_ERROR(reports::WriteGapHtml(*report, out.path()));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File(chosen->stem + ".updated.yaml"), *updated));
  out.Commit();
  for (const auto& line : chosen->lines) std::printf("vehicle: %s\n", line.c_str());
  std::fputs(gap::Summary(*report).c_str(), stdout);
  return Status::Ok();
}

struct SelftestArgs {
  gap::SelftestOptions options;
  std::string json;
  int jobs = 0;  // 0: every core
};

void Progress(int done, int total) {
  std::fprintf(stderr, "\rgap selftest: %d/%d", done, total);
  if (done == total) std::fputc('\n', stderr);
}

Status SelftestCommand(const SelftestArgs& a, int* exit_code) {
  if (a.options.profile != "real" && a.options.profile != "ideal") {
    return Status::BadInput("--profile: '" + a.options.profile + "': expected real or ideal");
  }
  // The trials run in forked workers (batch's process pool), one per core; the results do not
  // depend on the number of workers.
  const int jobs = a.jobs > 0 ? a.jobs : std::max(1, static_cast<int>(sysconf(_SC_NPROCESSORS_ONLN)));
  const bool tty = isatty(2) != 0;
  gap::TrialRunner runner = [jobs, tty](size_t n, const gap::TrialFn& one) {
    return batch::RunForkedMap(n, one, jobs, [tty](size_t done, size_t total) {
      if (tty) Progress(static_cast<int>(done), static_cast<int>(total));
    });
  };
  auto r = gap::RunSelftest(a.options, nullptr, runner);
  if (!r.ok()) return r.status();
  if (!a.json.empty()) HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(a.json, r->json.dump(2) + "\n"));
  std::fputs(r->table.c_str(), stdout);
  *exit_code = r->targets_met ? 0 : 1;
  return Status::Ok();
}

}  // namespace

void AddGapCommand(CLI::App& app, int* exit_code) {
  CLI::App* gap = app.add_subcommand("gap", "Sim-to-real gap: diagnose a real log, or the blind selftest");
  gap->require_subcommand(1);
  auto d = std::make_shared<DiagnoseArgs>();
  CLI::App* diag = gap->add_subcommand("diagnose", "Where the gap lies, which effect causes it, how much it shrinks");
  diag->add_option("--real", d->real, "FlightLog CSV (its .meta.json beside it)")->required();
  diag->add_option("--sim", d->sim_config, "Vehicle name under worlds/vehicles or a vehicle YAML (default: the vehicle identified from the log on "
                 "fitting blocks, diagnosed on held-out blocks)");
  diag->add_option("--out", d->out, "Output directory (gap.json, gap.html, <vehicle>.updated.yaml)")->required();
  diag->add_option("--seed", d->seed, "Bootstrap seed")->capture_default_str();
  diag->add_option("--from", d->from_s, "Diagnose only from this log time (s), overriding the flight windows");
  diag->add_option("--to", d->to_s, "Diagnose only up to this log time (s)");
  diag->callback([d, exit_code] {
    const Status s = DiagnoseCommand(*d);
    *exit_code = s.ok() ? 0 : Report(s);
  });
  auto st = std::make_shared<SelftestArgs>();
  CLI::App* self = gap->add_subcommand("selftest", "Blind check on pseudo-real simulated logs with withheld effects");
  self->add_option("--trials", st->options.trials, "Trials per class")->capture_default_str();
  self->add_option("--seed", st->options.seed, "Seed")->capture_default_str();
  self->add_option("--profile", st->options.profile, "real: logs at real rates with nuisance terms and out-of-library "
                   "forms; ideal: the first wave's logs")
      ->capture_default_str();
  self->add_option("--threshold-trials", st->options.threshold_trials, "Trials per magnitude in the threshold sweep")
      ->capture_default_str();
  self->add_option("--json", st->json, "Also write hexsim.gap_selftest/1 JSON here");
  self->add_option("--jobs,-j", st->jobs, "Trials run in parallel, each in its own process (default: every core)");
  self->callback([st, exit_code] {
    const Status s = SelftestCommand(*st, exit_code);
    if (!s.ok()) *exit_code = Report(s);
  });
}

}  // namespace hexsim::app
