// The gap diagnosis report (moved from gap/, which no longer depends on render/): gap.html with PNG plots beside it (relative links): per channel the residual against time with
// the flight phases shaded, the residual against the chosen regressor, and before/after the fit.
#pragma once

#include <string>

#include "hexsim/common/status.h"
#include "hexsim/gap/diagnose.h"

namespace hexsim::reports {

// Writes `dir`/gap.html and `dir`/gap_<channel>_*.png (each atomically).
Status WriteGapHtml(const gap::GapReport& report, const std::string& dir);

}  // namespace hexsim::reports
