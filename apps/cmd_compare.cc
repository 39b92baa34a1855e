// hexsim compare MISSION [--calibrations a,b,...] [--seeds N] --out DIR: the same mission flown
// with each compass calibration (each learnt on the simulated turntable from sensor data), the
// paper's Table 1 for the same calibrations, comparison.json, a text table, plots and report.html.
#include <atomic>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "calibration_setup.h"
#include "cli_util.h"
#include "commands.h"
#include "compare_stats.h"
#include "hexsim/common/atomic_file.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/magnetics/heading_error.h"
#include "hexsim/sim/run_config.h"
#include "hexsim/sim/turntable.h"
#include "report.h"
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

struct Job {
  std::string calibration;
  uint64_t seed = 0;
  nlohmann::json summary;
  Status status;
};

Status CompareCommand(CompareArgs a) {
  if (a.seeds < 1 || a.seeds > 1000) return Status::BadInput(fmt::format("--seeds: must be in 1..1000 (got {})", a.seeds));
  const std::vector<std::string> cals = SplitList(a.calibrations);
  if (cals.empty()) return Status::BadInput("--calibrations: at least one");
  // Validate everything before writing anything.
  auto base = sim::LoadRunSetup(a.request);
  if (!base.ok()) return base.status();
  for (const auto& c : cals) {
    if (c != "none") {
      const auto names = magnetics::CompensatorNames();
      if (std::find(names.begin(), names.end(), c) == names.end() && c.find(".yaml") == std::string::npos) {
        return Status::BadInput("--calibrations: unknown calibration '" + c + "'");
      }
    }
  }
  OutputDirectory out;
  HEXSIM_RETURN_IF_ERROR(out.Open(a.out));

  std::vector<Job> jobs;
  for (const auto& c : cals) {
    for (int s = 0; s < a.seeds; ++s) jobs.push_back({c, a.request.seed + static_cast<uint64_t>(s), {}, {}});
  }
  std::atomic<size_t> next{0};
  std::mutex io;
  auto worker = [&] {
    for (size_t i = next++; i < jobs.size(); i = next++) {
      Job& job = jobs[i];
      sim::RunRequest req = a.request;
      req.seed = job.seed;
      auto setup = sim::LoadRunSetup(req);
      if (!setup.ok()) {
        job.status = setup.status();
        continue;
      }
      job.status = AttachCalibration(job.calibration, &*setup);
      if (!job.status.ok()) continue;
      sim::RunOutput r = sim::RunMission(*setup);
      const std::string dir = out.File(fmt::format("{}/seed_{}", job.calibration, job.seed));
      job.status = EnsureDirectory(dir);
      if (job.status.ok()) job.status = logs::WriteFlightLog(r.log, dir + "/log.csv");
      if (job.status.ok()) job.status = WriteFileAtomic(dir + "/summary.json", r.summary.dump(2) + "\n");
      job.summary = r.summary;
      std::lock_guard<std::mutex> lock(io);
      std::fprintf(stderr, "compare: %-17s seed %-4llu %-13s yaw max %6.2f deg  cross-track rms %5.2f m\n",
                   job.calibration.c_str(), static_cast<unsigned long long>(job.seed),
                   r.summary["status"].get<std::string>().c_str(), r.summary["yaw_error_deg"]["max"].get<double>(),
                   r.summary["cross_track_m"]["rms"].get<double>());
    }
  };
  const int n_threads = std::max(1, std::min<int>(a.jobs > 0 ? a.jobs : static_cast<int>(std::thread::hardware_concurrency()),
                                                  static_cast<int>(jobs.size())));
  std::vector<std::thread> threads;
  threads.reserve(static_cast<size_t>(n_threads));
  for (int t = 0; t < n_threads; ++t) threads.emplace_back(worker);
  for (auto& t : threads) t.join();
  for (const auto& j : jobs) HEXSIM_RETURN_IF_ERROR(j.status);

  nlohmann::json cmp;
  cmp["schema"] = "hexsim.comparison/1";
  cmp["mission"] = base->mission_name;
  cmp["vehicle"] = base->vehicle_name;
  cmp["world"] = base->world_name;
  cmp["estimator"] = base->options.estimator;
  cmp["runs"] = nlohmann::json::array();
  for (const auto& j : jobs) cmp["runs"].push_back({{"calibration", j.calibration}, {"seed", j.seed}, {"summary", j.summary}});
  cmp["groups"] = nlohmann::json::array();
  for (const auto& c : cals) {
    std::vector<nlohmann::json> sums;
    for (const auto& j : jobs) {
      if (j.calibration == c) sums.push_back(j.summary);
    }
    cmp["groups"].push_back({{"calibration", c}, {"n", sums.size()}, {"metrics", GroupMetrics(sums)}});
  }

  // The paper's Table 1 for the same calibrations (learnt with the first seed), on an independent turn.
  {
    sim::TurntableOptions opt;
    opt.planes = {"xy"};
    opt.seed = 7919;
    auto rows = sim::RunTurntable(base->vehicle, base->world, opt);
    if (!rows.ok()) return rows.status();
    const auto turn = sim::ToMagSamples(*rows, 0);
    nlohmann::json he;
    he["schema"] = "hexsim.heading_error/1";
    he["control_u"] = opt.control_u;
    he["rows"] = nlohmann::json::array();
    for (const auto& c : cals) {
      // The same calibration the first seed flew with (a method learnt on the turntable, or a file).
      sim::RunSetup s = *base;
      HEXSIM_RETURN_IF_ERROR(AttachCalibration(c, &s));
      std::shared_ptr<const magnetics::Compensator> comp =
          s.compensator ? s.compensator : std::shared_ptr<const magnetics::Compensator>(magnetics::MakeNoneCompensator());
      auto eval = magnetics::EvaluateHeadingError(*comp, turn, magnetics::HeadingErrorOptions{});
      if (!eval.ok()) return eval.status();
      std::vector<double> mx, rms, cur;
      for (const auto& e : *eval) {
        mx.push_back(e.max_abs_deg);
        rms.push_back(e.rms_deg);
        cur.push_back(e.mean_current_A);
      }
      he["rows"].push_back({{"name", c == "none" ? "uncorrected" : c}, {"method", c}, {"max_deg", mx},
                            {"rms_deg", rms}, {"current_A", cur}});
    }
    cmp["heading_error"] = he;
  }

  const std::string table = CompareTable(cmp);
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("comparison.txt"), table));
  if (!a.no_report) HEXSIM_RETURN_IF_ERROR(WriteCompareReport(cmp, out.path()));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("comparison.json"), cmp.dump(2) + "\n"));
  out.Commit();
  std::fputs(table.c_str(), stdout);
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
  c->add_option("--jobs", a->jobs, "Parallel runs (default: all cores)");
  c->add_flag("--no-report", a->no_report, "Skip plots and report.html");
  c->add_option("--out", a->out, "Output directory")->required();
  c->callback([a, exit_code] { *exit_code = Report(CompareCommand(*a)); });
}

}  // namespace hexsim::app
