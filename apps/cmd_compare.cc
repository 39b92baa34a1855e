// hexsim compare MISSION [--calibrations a,b,...] [--seeds N] --out DIR: the same mission flown
// with each compass calibration (each learnt on the simulated turntable from sensor data), the
// paper's Table 1 for the same calibrations, comparison.json, a text table, plots and report.html.
// The experiment is experiments::RunComparison; the report, reports::WriteCompareReport.
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <string>

#include "cli_util.h"
#include "commands.h"
#include "hexsim/common/atomic_file.h"
#include "hexsim/experiments/compare.h"
#include "hexsim/reports/compare_report.h"
#include "hexsim/reports/headline.h"
#include "turntable_util.h"

namespace hexsim::app {

namespace {

struct CompareArgs {
  sim::RunRequest request;
  std::string calibrations = "none,traditional,adaptive,adaptive-current,compassmot,px4-ls";
  int seeds = 3;
  int jobs = 0;
  bool no_report = false;
  std::string out;
};

Status CompareCommand(const CompareArgs& a) {
  experiments::CompareOptions o;
  o.request = a.request;
  o.calibrations = SplitList(a.calibrations);
  o.seeds = a.seeds;
  const int cores = std::max(1, static_cast<int>(sysconf(_SC_NPROCESSORS_ONLN)));
  o.jobs = std::max(1, std::min(a.jobs > 0 ? a.jobs : cores, static_cast<int>(o.calibrations.size()) * std::max(1, a.seeds)));
  o.evidence = !a.no_report;
  // Validate everything before writing anything.
  HEXSIM_RETURN_IF_ERROR(o.IsValid());
  auto base = sim::LoadRunSetup(a.request);
  if (!base.ok()) return base.status();
  OutputDirectory out;
  HEXSIM_RETURN_IF_ERROR(out.Open(a.out));
  auto result = experiments::RunComparison(o, out.path());
  if (!result.ok()) return result.status();
  const std::string table = experiments::ComparisonTable(result->comparison);
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("comparison.txt"), table));
  if (!a.no_report) HEXSIM_RETURN_IF_ERROR(reports::WriteCompareReport(result->comparison, result->evidence, out.path()));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("comparison.json"), experiments::ToJson(result->comparison).dump(2) + "\n"));
  out.Commit();
  std::fputs(table.c_str(), stdout);
  for (const std::string& sentence : reports::CompareHeadline(result->comparison)) std::printf("%s\n", sentence.c_str());
  std::printf("compare: %s\n", out.File(a.no_report ? "comparison.json" : "report.html").c_str());
  return Status::Ok();
}

}  // namespace

void AddCompareCommand(CLI::App& app, int* exit_code) {
  auto a = std::make_shared<CompareArgs>();
  a->request.mission = "climb_cruise_square";
  a->request.vehicle = "paper_hex";
  a->request.world = "changchun";
  CLI::App* c = app.add_subcommand("compare", "Fly one mission with each compass calibration and compare");
  c->add_option("mission", a->request.mission, "Mission name or YAML path")->capture_default_str();
  c->add_option("--vehicle", a->request.vehicle, "Vehicle")->capture_default_str();
  c->add_option("--world", a->request.world, "Environment")->capture_default_str();
  c->add_option("--calibrations", a->calibrations, "Comma-separated calibrations")->capture_default_str();
  c->add_option("--seeds", a->seeds, "Seeds per calibration")->capture_default_str();
  c->add_option("--seed", a->request.seed, "First seed")->capture_default_str();
  c->add_option("--estimator", a->request.estimator, "eskf|complementary|truth");
  c->add_option("--duration", a->request.duration_s, "Stop each run after this many seconds");
  c->add_option("--set", a->request.sets, "Override a parameter (KEY=VALUE)");
  c->add_option("--jobs", a->jobs, "Parallel runs, each in its own process (default: all cores)");
  c->add_flag("--no-report", a->no_report, "Skip plots and report.html");
  c->add_option("--out", a->out, "Output directory")->required();
  c->callback([a, exit_code] { *exit_code = Report(CompareCommand(*a)); });
}

}  // namespace hexsim::app
