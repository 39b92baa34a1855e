// The identification report (moved from identify/, which no longer depends on render/): identify.html
// with PNG plots beside it (measured against predicted outputs, the steady-hover samples).
#pragma once

#include <string>

#include "hexsim/common/status.h"
#include "hexsim/identify/identify.h"

namespace hexsim::reports {

// Writes `dir`/identify.html and `dir`/identify_*.png (each atomically).
Status WriteIdentifyHtml(const identify::IdentifyResult& result, const std::string& dir);

}  // namespace hexsim::reports
