// What `hexsim step|freqresp|disturb` write (experiments/response_tests.h flies them): the test's
// JSON (hexsim.step/1, hexsim.freqresp/1, hexsim.disturb/1), a text summary, the series as CSV and a
// plot, into an open output directory. Each returns the text summary it wrote; none recomputes.
#pragma once

#include <string>

#include "hexsim/common/atomic_file.h"
#include "hexsim/common/status.h"
#include "hexsim/experiments/response_tests.h"

namespace hexsim::reports {

// step.json, step.txt, step.csv, step.png
Result<std::string> WriteStepReport(const sim::RunSetup& setup, const experiments::StepRequest& request,
                                    const experiments::StepRun& run, const OutputDirectory& out);
// freqresp.json, freqresp.txt, freqresp.csv, excitation.csv, bode.png
Result<std::string> WriteFreqReport(const sim::RunSetup& setup, const experiments::FreqRequest& request,
                                    const experiments::FreqRun& run, const sim::HoverOptions& hover,
                                    const OutputDirectory& out);
// disturb.json, disturb.txt, disturb.csv, disturb.png
Result<std::string> WriteDisturbReport(const sim::RunSetup& setup, const sim::DisturbanceSpec& spec,
                                       const sim::DisturbTestResult& result, const OutputDirectory& out);

}  // namespace hexsim::reports
