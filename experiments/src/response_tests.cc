#include "hexsim/experiments/response_tests.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace hexsim::experiments {

Result<StepRun> RunStep(const sim::RunSetup& setup, const StepRequest& request, const sim::HoverOptions& hover) {
  auto axis = sim::ParseResponseAxis(request.axis);
  if (!axis.ok()) return axis.status();
  const bool attitude = sim::IsAttitudeAxis(*axis);
  const double after_s = request.duration_s > 0 ? request.duration_s : (attitude ? 4.0 : 15.0);
  auto r = sim::RunStepTest(setup, *axis, request.size, after_s, hover);
  if (!r.ok()) return r.status();
  StepRun run;
  run.axis = *axis;
  run.result = std::move(*r);
  return run;
}

Result<FreqRun> RunFreq(const sim::RunSetup& setup, const FreqRequest& request, const sim::HoverOptions& hover) {
  auto axis = sim::ParseResponseAxis(request.axis);
  if (!axis.ok()) return axis.status();
  const bool attitude = sim::IsAttitudeAxis(*axis);
  FreqRun run;
  run.axis = *axis;
  sim::FreqTestOptions& o = run.options;
  o.f_lo_hz = request.f_lo_hz > 0 ? request.f_lo_hz : (attitude ? 0.2 : 0.05);
  o.f_hi_hz = request.f_hi_hz > 0 ? request.f_hi_hz : (attitude ? 8.0 : 3.0);
  const double attitude_amplitude = *axis == sim::ResponseAxis::kYaw ? 8.0 : 4.0;
  o.amplitude = request.amplitude > 0 ? request.amplitude : (attitude ? attitude_amplitude : 0.5);
  o.period_samples = attitude ? 2048 : 4096;  // 10.24 s / 20.48 s at 200 Hz
  o.periods = request.periods;
  o.min_coherence = request.min_coherence;
  auto r = sim::RunFrequencyTest(setup, *axis, o, hover);
  if (!r.ok()) return r.status();
  run.result = std::move(*r);
  return run;
}

Result<sim::DisturbanceSpec> ParseDisturbance(const std::string& gust, sim::DisturbanceSpec spec) {
  if (gust.empty()) return spec;
  const std::string what = "--gust";
  std::stringstream ss(gust);
  std::string item;
  int i = 0;
  while (std::getline(ss, item, ',')) {
    if (i >= 3) return Status::BadInput(what + ": expected N,E,D");
    try {
      size_t used = 0;
      spec.gust_N_mps[i] = std::stod(item, &used);
      if (used != item.size() || !std::isfinite(spec.gust_N_mps[i])) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      std::string msg = what;
      msg += ": '";
      msg += item;
      msg += "' is not a number";
      return Status::BadInput(msg);
    }
    ++i;
  }
  if (i != 3) return Status::BadInput(what + ": expected N,E,D");
  return spec;
}

std::string DisturbanceKind(const sim::DisturbanceSpec& spec) {
  if (spec.payload_release_kg > 0 && !spec.gust_N_mps.isZero()) return "gust+payload_release";
  return spec.payload_release_kg > 0 ? "payload_release" : "gust";
}

}  // namespace hexsim::experiments
