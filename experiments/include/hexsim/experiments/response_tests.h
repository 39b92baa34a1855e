// The controller-development experiments at hover (`hexsim step|freqresp|disturb`): a request with
// the command's per-axis defaults (0 = choose for the axis), resolved and flown through
// sim/hover_tests.h. reports/response_report.h writes what they return.
#pragma once

#include <string>

#include <Eigen/Core>

#include "hexsim/common/status.h"
#include "hexsim/sim/hover_tests.h"
#include "hexsim/sim/run_config.h"

namespace hexsim::experiments {

struct StepRequest {
  std::string axis = "roll";  // roll|pitch|yaw|alt|vel_N
  double size = 0.0;          // deg for angles, m for alt, m/s for vel_N
  double duration_s = 0.0;    // recorded after the step; 0: 4 s for angles, 15 s otherwise
};
struct StepRun {
  sim::ResponseAxis axis = sim::ResponseAxis::kRoll;
  sim::StepTestResult result;
};
Result<StepRun> RunStep(const sim::RunSetup& setup, const StepRequest& request, const sim::HoverOptions& hover);

struct FreqRequest {
  std::string axis = "roll";
  double f_lo_hz = 0.0;    // 0: 0.2 Hz for angles, 0.05 Hz otherwise
  double f_hi_hz = 0.0;    // 0: 8 Hz for angles, 3 Hz otherwise
  double amplitude = 0.0;  // 0: 4 deg (8 deg yaw) for angles, 0.5 otherwise
  int periods = 4;
  double min_coherence = 0.8;
};
struct FreqRun {
  sim::ResponseAxis axis = sim::ResponseAxis::kRoll;
  sim::FreqTestOptions options;  // as resolved for the axis
  sim::FreqTestResult result;
};
Result<FreqRun> RunFreq(const sim::RunSetup& setup, const FreqRequest& request, const sim::HoverOptions& hover);

// `gust` is the command line's "N,E,D" (m/s), empty for none.
Result<sim::DisturbanceSpec> ParseDisturbance(const std::string& gust, sim::DisturbanceSpec spec);
// gust | payload_release | gust+payload_release
std::string DisturbanceKind(const sim::DisturbanceSpec& spec);

}  // namespace hexsim::experiments
