// Verdicts (private to gap/). CONTRACTS.md "The verdict is a decomposition" orders the compass verdict: (1) no
// structure above the noise floor after the (timing-aligned) baseline: the out-of-range nuisance or
// timing term, else none; (2) structure: the effect with the largest held-out
// explained_share, if it reaches 0.5 and is plausible, chosen by the one-standard-error rule over
// the CV folds (the fewest parameters among the candidates within one standard error of the best);
// ambiguous when another candidate as simple is within one standard error and neither nests the
// other; (3) otherwise unexplained, with residual_left.
#pragma once

#include <string>
#include <vector>

#include "attribution.h"
#include "channels.h"
#include "hexsim/common/rng.h"

namespace hexsim::gap::internal {

// Which manoeuvre separates two collinear candidates.
std::string SeparatingManoeuvre(const std::string& a, const std::string& b);

// The rule of the gyro, accel and dynamics channels (verdict_inertial.cc).
ChannelResult AnalyzeInertial(const ChannelData& ch, const logs::FlightLog& log, const std::vector<std::string>& phases,
                               const DiagnoseOptions& o, RngStream* rng);

// What the timing scan found for one compass (nuisance.cc).
struct CompassTiming {
  Timing report;  // reported under `timing`
  bool latency_ok = false;
  double latency_s = 0.0, latency_ci95_s[2] = {0.0, 0.0};
  double latency_share = 0.0;        // held-out share of the unaligned baseline residual the alignment removes
  double staleness_s = 0.0;
};

// The nuisance baseline's estimates as findings (nuisance.cc).
struct NuisanceReport {
  Nuisance nuisance;  // reported under `nuisance`
  std::vector<CandidateResult> terms;  // hard_iron_offset, local_anomaly, scale_error as candidates
  std::string out_of_range;            // the term named as the verdict when nothing else is found
  std::vector<std::string> findings;   // plain language
};
NuisanceReport DescribeNuisance(const ChannelData& ch, const Evaluated& baseline, const DiagnoseOptions& o);
// A compass misaligned by φ whose readings carry a field-norm error s (a sensor scale, or a field of
// another size) reads (1 + s)·R(φ)·h: the linear residual φ × h of the prediction h holds (1 + s)·φ.
// The angle is the coefficient over the baseline's fitted field scale |B_fit|/|B_WMM| (nuisance.cc):
// the misalignment's magnitude, interval and parameters divided by it.
void DescaleMisalignment(double field_scale, CandidateResult* r);

// The rule of compass channels (verdict.cc).
ChannelResult AnalyzeCompass(const ChannelData& ch, const logs::FlightLog& log, const std::vector<std::string>& phases,
                             const DiagnoseOptions& o, const CompassTiming& timing, RngStream* rng);

}  // namespace hexsim::gap::internal
