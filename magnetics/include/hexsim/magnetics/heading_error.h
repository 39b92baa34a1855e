// The paper's Table 1 experiment: heading error of a compensated compass over one full 360° turn
// in the level X-Y plane, per control amount.
//
// error = ψ(compensated reading) − ψ(true Earth field in body frame), both with the exact
// tilt-compensated formula (heading.h) at the sample's true roll and pitch, wrapped to ±180°.
// Declination cancels in the difference.
#pragma once

#include <string>
#include <vector>

#include "hexsim/common/status.h"
#include "hexsim/magnetics/compensator.h"

namespace hexsim::magnetics {

struct HeadingErrorOptions {
  std::string plane = "xy";          // which turntable plane to evaluate
  int min_samples_per_turn = 8;
  double max_angle_gap_deg = 45.0;   // a "full turn": no gap between table angles wider than this
  Status IsValid() const;
};

struct HeadingErrorRow {
  double control_u = 0.0;
  double mean_current_A = 0.0;
  int num_samples = 0;
  double max_abs_deg = 0.0;  // Table 1's figure
  double rms_deg = 0.0;
  double mean_deg = 0.0;
};

// One row per control amount (ascending). BadInput when there are no samples in `plane`, a
// control amount's turn is incomplete, or a sample lacks its true Earth field (earth_B_uT = 0).
Result<std::vector<HeadingErrorRow>> EvaluateHeadingError(const Compensator& compensator,
                                                          const std::vector<MagSample>& samples,
                                                          const HeadingErrorOptions& options);

// Heading error (deg, ±180) of one sample under `compensator`.
double SampleHeadingErrorDeg(const Compensator& compensator, const MagSample& sample);

}  // namespace hexsim::magnetics
