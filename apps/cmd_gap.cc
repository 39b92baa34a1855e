// hexsim gap diagnose --real LOG.csv|LOG.bin|LOG.ulg [--sim VEHICLE_OR_CONFIG] --out DIR [--from S --to S]
// hexsim gap selftest [--profile real|ideal] [--trials N] [--seed S] [--jobs N] [--json FILE]
#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>
#include <unistd.h>

#include <fmt/format.h>

#include "cli_util.h"
#include "commands.h"
#include "hexsim/batch/pool.h"
#include "hexsim/common/atomic_file.h"
#include "hexsim/experiments/log_diagnosis.h"
#include "hexsim/gap/selftest.h"
#include "hexsim/gap/selftest_json.h"
#include "hexsim/logs/read_log.h"
#include "hexsim/reports/gap_report.h"

namespace hexsim::app {
namespace {

struct DiagnoseArgs {
  std::string real, out;
  experiments::LogDiagnosisOptions options;
  int jobs = 0;  // 0: every core
};

Status DiagnoseCommand(DiagnoseArgs a) {
  if (a.jobs < 0) return Status::BadInput(fmt::format("--jobs: must be 0 (every core) or more (got {})", a.jobs));
  a.options.threads = a.jobs > 0 ? a.jobs : std::max(1, static_cast<int>(sysconf(_SC_NPROCESSORS_ONLN)));
  std::vector<std::string> notes;
  auto log = logs::ReadAnyFlightLog(a.real, &notes);
  if (!log.ok()) return log.status();
  for (const auto& line : notes) std::printf("log: %s\n", line.c_str());
  experiments::LogDiagnosisOptions options = a.options;
  options.log_name = a.real;
  auto d = experiments::DiagnoseLog(*log, options);
  if (!d.ok()) return d.status();
  OutputDirectory out;
  HEXSIM_RETURN_IF_ERROR(out.Open(a.out));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("gap.json"), experiments::LogDiagnosisJson(*d).dump(2) + "\n"));
  if (d->identified) HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("identified.yaml"), d->vehicle_yaml));
  HEXSIM_RETURN_IF_ERROR(reports::WriteGapHtml(d->report, out.path()));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File(d->stem + ".updated.yaml"), d->updated_yaml));
  // Parameters to paste, with calibrate's writer, from the compasses' in-flight model.
  std::vector<gap::CompassTerms> terms;
  for (const auto& c : d->report.channels) {
    if (c.absolute_terms) terms.push_back(*c.absolute_terms);
  }
  const gap::ParamFiles params = gap::CompassParamFiles(terms);
  if (!params.parm.empty()) {
    HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("calib.parm"), params.parm));
    HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("calib.params"), params.params));
  }
  out.Commit();
  for (const auto& line : d->lines) std::printf("vehicle: %s\n", line.c_str());
  std::fputs(gap::Summary(d->report).c_str(), stdout);
  if (!params.parm.empty()) std::printf("parameters to paste: %s/calib.parm (ArduPilot), %s/calib.params (PX4)\n", a.out.c_str(), a.out.c_str());
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
  // The trials run in forked workers (batch's process pool), one per core, each record passed back
  // as JSON; the results do not depend on the number of workers.
  const int jobs = a.jobs > 0 ? a.jobs : std::max(1, static_cast<int>(sysconf(_SC_NPROCESSORS_ONLN)));
  const bool tty = isatty(2) != 0;
  gap::TrialRunner runner = [jobs, tty](size_t n, const gap::TrialFn& one) -> Result<std::vector<gap::TrialRecord>> {
    auto as_json = [&one](size_t i) -> Result<nlohmann::json> {
      auto r = one(i);
      if (!r.ok()) return r.status();
      return gap::ToJson(*r);
    };
    auto outs = batch::RunForkedMap(n, as_json, jobs, [tty](size_t done, size_t total) {
      if (tty) Progress(static_cast<int>(done), static_cast<int>(total));
    });
    if (!outs.ok()) return outs.status();
    std::vector<gap::TrialRecord> records;
    for (const auto& j : *outs) {
      auto r = gap::TrialRecordFromJson(j);
      if (!r.ok()) return r.status();
      records.push_back(std::move(*r));
    }
    return records;
  };
  auto r = gap::RunSelftest(a.options, nullptr, runner);
  if (!r.ok()) return r.status();
  if (!a.json.empty()) HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(a.json, gap::ToJson(*r).dump(2) + "\n"));
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
  diag->add_option("--real", d->real, "FlightLog CSV (its .meta.json beside it), or an ArduPilot .bin / PX4 .ulg "
                                      "(imported in memory)")->required();
  diag->add_option("--sim", d->options.vehicle, "Vehicle name under worlds/vehicles or a vehicle YAML (default: the vehicle identified from the log on "
                 "fitting blocks; gyro, accel and dynamics diagnosed on held-out blocks, the compasses on every block)");
  diag->add_option("--out", d->out, "Output directory (gap.json, gap.html, <vehicle>.updated.yaml)")->required();
  diag->add_option("--seed", d->options.seed, "Bootstrap seed")->capture_default_str();
  diag->add_option("--from", d->options.from_s, "Diagnose only from this log time (s), overriding the flight windows");
  diag->add_option("--to", d->options.to_s, "Diagnose only up to this log time (s)");
  diag->add_option("--jobs,-j", d->jobs, "Channels diagnosed at once, each on its own thread (default 0: every core; "
                                         "the report is the same for any count)");
  diag->callback([d, exit_code] {
    const Status s = DiagnoseCommand(*d);
    *exit_code = s.ok() ? 0 : Report(s);
  });
  auto st = std::make_shared<SelftestArgs>();
  CLI::App* self = gap->add_subcommand("selftest", "Blind check on pseudo-real simulated logs with withheld effects");
  self->add_option("--trials", st->options.trials, "Trials per class")->capture_default_str();
  self->add_option("--seed", st->options.seed, "Seed")->capture_default_str();
  self->add_option("--profile", st->options.profile, "real: logs at real rates with nuisance terms and out-of-library "
                   "forms; ideal: exact logs (100 Hz rows, exact timing)")
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
