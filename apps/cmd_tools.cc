// Response tools for controller development (hover experiments built on sim::Simulation):
//   hexsim step     --axis roll|pitch|yaw|alt|vel_N --size X [--duration S] --out DIR
//   hexsim freqresp --axis ... [--f-lo HZ --f-hi HZ --amplitude A --periods N] --out DIR
//   hexsim disturb  (--gust N,E,D | --payload-release KG) [--gust-duration S] --out DIR
// Common: [--vehicle V] [--world W] [--estimator truth|eskf|complementary] [--seed N]
//         [--set KEY=VALUE ...] [--hover-alt M] [--settle S]
#include <cstdio>
#include <memory>
#include <string>

#include "cli_util.h"
#include "commands.h"
#include "hexsim/experiments/response_tests.h"
#include "hexsim/reports/response_report.h"

namespace hexsim::app {

namespace {

struct CommonArgs {
  sim::RunRequest request;
  sim::HoverOptions hover;
  std::string out;
};

void AddCommon(CLI::App* cmd, CommonArgs* a) {
  a->request.estimator = "truth";  // response of the loop itself; --estimator eskf flies on the estimate
  cmd->add_option("--vehicle", a->request.vehicle, "Vehicle name or YAML path")->capture_default_str();
  cmd->add_option("--world", a->request.world, "Environment name or YAML path")->capture_default_str();
  cmd->add_option("--estimator", a->request.estimator, "truth|eskf|complementary")->capture_default_str();
  cmd->add_option("--seed", a->request.seed, "Random seed")->capture_default_str();
  cmd->add_option("--set", a->request.sets, "Override a parameter, e.g. control.rate.roll.kp=20");
  cmd->add_option("--hover-alt", a->hover.hover_alt_m, "Hover altitude (m)")->capture_default_str();
  cmd->add_option("--settle", a->hover.settle_s, "Take-off and settling time before the test (s)")->capture_default_str();
  cmd->add_option("--out", a->out, "Output directory")->required();
}

// Loads the setup, opens the output directory, flies `run` and writes its report with `write`.
template <typename RunFn, typename WriteFn>
Status Tool(const CommonArgs& a, RunFn run, WriteFn write) {
  auto setup = sim::LoadRunSetup(a.request);
  if (!setup.ok()) return setup.status();
  OutputDirectory out;
  HEXSIM_RETURN_IF_ERROR(out.Open(a.out));
  auto result = run(*setup);
  if (!result.ok()) return result.status();
  auto text = write(*setup, *result, out);
  if (!text.ok()) return text.status();
  out.Commit();
  std::fputs(text->c_str(), stdout);
  return Status::Ok();
}

struct StepArgs {
  CommonArgs common;
  experiments::StepRequest request;
};

Status StepCommand(const StepArgs& a) {
  if (auto axis = sim::ParseResponseAxis(a.request.axis); !axis.ok()) return axis.status();
  return Tool(
      a.common, [&](const sim::RunSetup& s) { return experiments::RunStep(s, a.request, a.common.hover); },
      [&](const sim::RunSetup& s, const experiments::StepRun& r, const OutputDirectory& out) {
        return reports::WriteStepReport(s, a.request, r, out);
      });
}

struct FreqArgs {
  CommonArgs common;
  experiments::FreqRequest request;
};

Status FreqCommand(const FreqArgs& a) {
  if (auto axis = sim::ParseResponseAxis(a.request.axis); !axis.ok()) return axis.status();
  return Tool(
      a.common, [&](const sim::RunSetup& s) { return experiments::RunFreq(s, a.request, a.common.hover); },
      [&](const sim::RunSetup& s, const experiments::FreqRun& r, const OutputDirectory& out) {
        return reports::WriteFreqReport(s, a.request, r, a.common.hover, out);
      });
}

struct DisturbArgs {
  CommonArgs common;
  std::string gust;  // "N,E,D"
  sim::DisturbanceSpec spec;
};

Status DisturbCommand(const DisturbArgs& a) {
  auto spec = experiments::ParseDisturbance(a.gust, a.spec);
  if (!spec.ok()) return spec.status();
  return Tool(
      a.common, [&](const sim::RunSetup& s) { return sim::RunDisturbTest(s, *spec, a.common.hover); },
      [&](const sim::RunSetup& s, const sim::DisturbTestResult& r, const OutputDirectory& out) {
        return reports::WriteDisturbReport(s, *spec, r, out);
      });
}

template <typename Args, typename Fn>
void Bind(CLI::App* cmd, std::shared_ptr<Args> args, int* exit_code, Fn fn) {
  cmd->callback([args, exit_code, fn] {
    const Status s = fn(*args);
    *exit_code = s.ok() ? 0 : Report(s);
  });
}

}  // namespace

void AddToolCommands(CLI::App& app, int* exit_code) {
  {
    auto a = std::make_shared<StepArgs>();
    CLI::App* cmd = app.add_subcommand("step", "Step one loop's setpoint at hover; rise, overshoot, settling, error");
    cmd->add_option("--axis", a->request.axis, "roll|pitch|yaw|alt|vel_N")->required();
    cmd->add_option("--size", a->request.size, "Step size (deg for angles, m for alt, m/s for vel_N)")->required();
    cmd->add_option("--duration", a->request.duration_s, "Recorded after the step (s; default 4 for angles, 15 otherwise)");
    AddCommon(cmd, &a->common);
    Bind(cmd, a, exit_code, StepCommand);
  }
  {
    auto a = std::make_shared<FreqArgs>();
    CLI::App* cmd = app.add_subcommand("freqresp", "Multisine at hover: closed-loop Bode plot, bandwidth, margins");
    cmd->add_option("--axis", a->request.axis, "roll|pitch|yaw|alt|vel_N")->required();
    cmd->add_option("--f-lo", a->request.f_lo_hz, "Lowest frequency (Hz; default 0.2 angles, 0.05 otherwise)");
    cmd->add_option("--f-hi", a->request.f_hi_hz, "Highest frequency (Hz; default 8 angles, 3 otherwise)");
    cmd->add_option("--amplitude", a->request.amplitude, "Multisine peak (axis units; default 4 deg, 8 deg yaw, 0.5)");
    cmd->add_option("--periods", a->request.periods, "Periods averaged (Welch segments)")->capture_default_str();
    cmd->add_option("--min-coherence", a->request.min_coherence, "Lines below this coherence are not used")
        ->capture_default_str();
    AddCommon(cmd, &a->common);
    Bind(cmd, a, exit_code, FreqCommand);
  }
  {
    auto a = std::make_shared<DisturbArgs>();
    CLI::App* cmd = app.add_subcommand("disturb", "A wind gust or payload release at hover; peak deviation, recovery");
    cmd->add_option("--gust", a->gust, "Step in the mean wind N,E,D (m/s)");
    cmd->add_option("--gust-duration", a->spec.gust_duration_s, "Gust length (s; 0: stays)")->capture_default_str();
    cmd->add_option("--payload-release", a->spec.payload_release_kg, "Carry this payload (kg) and drop it")
        ->capture_default_str();
    cmd->add_option("--duration", a->spec.after_s, "Recorded after the onset (s)")->capture_default_str();
    cmd->add_option("--band", a->spec.recovery_band_m, "Recovered: deviation stays within this (m)")->capture_default_str();
    AddCommon(cmd, &a->common);
    Bind(cmd, a, exit_code, DisturbCommand);
  }
}

}  // namespace hexsim::app
