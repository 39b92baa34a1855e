// hexsim turntable | calibrate | heading-error: the paper's ground sampling, the fits, and Table 1.
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "cli_util.h"
#include "commands.h"
#include "hexsim/common/atomic_file.h"
#include "hexsim/experiments/ground_calibration.h"
#include "hexsim/magnetics/compensator.h"
#include "hexsim/magnetics/heading_error.h"
#include "turntable_util.h"

namespace hexsim::app {

namespace {

struct TurntableArgs {
  std::string vehicle = "paper_hex", world = "changchun", planes = "xy,yz,xz", control = "0,200,300", out;
  double step_deg = 5.0, soc = -1.0;
  uint64_t seed = 1;
};

Status TurntableCommand(const TurntableArgs& a) {
  auto vw = LoadVehicleAndWorld(a.vehicle, a.world);
  if (!vw.ok()) return vw.status();
  sim::TurntableOptions opt;
  opt.planes = SplitList(a.planes);
  auto controls = ParseNumberList(a.control, "--control");
  if (!controls.ok()) return controls.status();
  opt.control_u = *controls;
  opt.step_deg = a.step_deg;
  opt.seed = experiments::GroundSessionSeed(a.seed);  // the session `run`/`compare --seed N` learn from
  opt.soc = a.soc;
  HEXSIM_RETURN_IF_ERROR(opt.IsValid());
  auto rows = sim::RunTurntable(vw->vehicle, vw->world, opt);
  if (!rows.ok()) return rows.status();
  OutputDirectory out;
  HEXSIM_RETURN_IF_ERROR(out.Open(a.out));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("samples.csv"), sim::TurntableCsv(*rows)));
  out.Commit();
  std::printf("turntable: %zu samples (%zu planes x %zu control amounts) -> %s\n", rows->size(), opt.planes.size(),
              opt.control_u.size(), out.File("samples.csv").c_str());
  return Status::Ok();
}

struct HeadingErrorArgs {
  std::vector<std::string> calibs;
  std::string vehicle = "paper_hex", world = "changchun", control = "0,200,300", json;
  double step_deg = 5.0, soc = -1.0;
  uint64_t seed = experiments::kTable1TurnSeed;
};

Status HeadingErrorCommand(const HeadingErrorArgs& a) {
  struct Named {
    std::string name, method;
    std::shared_ptr<const magnetics::Compensator> comp;
  };
  std::vector<Named> rows_in;
  rows_in.push_back({"uncorrected", "none", magnetics::MakeNoneCompensator()});
  for (const auto& path : a.calibs) {
    // A file, read as run/compare read a --calibration file (named by its stem).
    std::error_code ec;
    if (experiments::IsCalibrationMethod(path) && !std::filesystem::is_regular_file(path, ec)) {
      return Status::BadInput("--calib " + path + ": expects a calib.yaml (hexsim calibrate writes one), not a method");
    }
    auto cal = experiments::MakeCalibration(path, std::vector<magnetics::MagSample>{});
    if (!cal.ok()) return cal.status();
    rows_in.push_back({cal->name, cal->compensator->name(), cal->compensator});
  }
  auto vw = LoadVehicleAndWorld(a.vehicle, a.world);
  if (!vw.ok()) return vw.status();
  sim::TurntableOptions opt;
  opt.planes = {"xy"};
  auto controls = ParseNumberList(a.control, "--control");
  if (!controls.ok()) return controls.status();
  opt.control_u = *controls;
  opt.step_deg = a.step_deg;
  opt.seed = a.seed;
  opt.soc = a.soc;
  auto rows = sim::RunTurntable(vw->vehicle, vw->world, opt);
  if (!rows.ok()) return rows.status();
  const auto samples = sim::ToMagSamples(*rows, 0);

  nlohmann::json j;
  j["schema"] = "hexsim.heading_error/1";
  j["vehicle"] = vw->vehicle_name;
  j["world"] = vw->world_name;
  j["control_u"] = opt.control_u;
  j["rows"] = nlohmann::json::array();
  std::string header = fmt::format("{:<22}", "heading error (deg)");
  for (double u : opt.control_u) header += fmt::format(" {:>14}", fmt::format("u={:g} max/rms", u));
  std::printf("%s\n", header.c_str());
  for (const auto& r : rows_in) {
    auto eval = magnetics::EvaluateHeadingError(*r.comp, samples, magnetics::HeadingErrorOptions{});
    if (!eval.ok()) return eval.status();
    std::vector<double> max_deg, rms_deg, current;
    std::string line = fmt::format("{:<22}", r.name);
    for (const auto& e : *eval) {
      max_deg.push_back(e.max_abs_deg);
      rms_deg.push_back(e.rms_deg);
      current.push_back(e.mean_current_A);
      line += fmt::format(" {:>14}", fmt::format("{:.2f} / {:.2f}", e.max_abs_deg, e.rms_deg));
    }
    std::printf("%s\n", line.c_str());
    j["rows"].push_back({{"name", r.name}, {"method", r.method}, {"max_deg", max_deg}, {"rms_deg", rms_deg},
                         {"current_A", current}});
  }
  if (!a.json.empty()) HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(a.json, j.dump(2) + "\n"));
  return Status::Ok();
}

}  // namespace

void AddCalibrationCommands(CLI::App& app, int* exit_code) {
  {
    auto a = std::make_shared<TurntableArgs>();
    CLI::App* c = app.add_subcommand("turntable", "The paper's ground sampling on a non-magnetic turntable -> samples.csv");
    c->add_option("--vehicle", a->vehicle, "Vehicle name or YAML path")->capture_default_str();
    c->add_option("--world", a->world, "Environment name or YAML path")->capture_default_str();
    c->add_option("--planes", a->planes, "Table planes: xy,yz,xz")->capture_default_str();
    c->add_option("--control", a->control, "Control amounts (0..1000), comma-separated")->capture_default_str();
    c->add_option("--step-deg", a->step_deg, "Table step between samples")->capture_default_str();
    c->add_option("--soc", a->soc, "Battery state of charge 0..1 (default: the vehicle's)");
    c->add_option("--seed", a->seed,
                  "Experiment seed: the ground session that `run`/`compare --seed N` learn their calibrations from "
                  "(so turntable, calibrate and heading-error give compare's Table 1)")
        ->capture_default_str();
    c->add_option("--out", a->out, "Output directory")->required();
    c->callback([a, exit_code] { *exit_code = Report(TurntableCommand(*a)); });
  }
  {
    auto a = std::make_shared<HeadingErrorArgs>();
    CLI::App* c = app.add_subcommand("heading-error", "The paper's Table 1: heading residual over a full level turn");
    c->add_option("--calib", a->calibs, "calib.yaml files (repeatable)");
    c->add_option("--vehicle", a->vehicle, "Vehicle")->capture_default_str();
    c->add_option("--world", a->world, "Environment")->capture_default_str();
    c->add_option("--control", a->control, "Control amounts")->capture_default_str();
    c->add_option("--step-deg", a->step_deg, "Table step")->capture_default_str();
    c->add_option("--soc", a->soc, "Battery state of charge 0..1 (default: the vehicle's)");
    c->add_option("--seed", a->seed, "Seed of the evaluation turn (independent of the calibration's)")->capture_default_str();
    c->add_option("--json", a->json, "Also write the table as JSON");
    c->callback([a, exit_code] { *exit_code = Report(HeadingErrorCommand(*a)); });
  }
}

}  // namespace hexsim::app
