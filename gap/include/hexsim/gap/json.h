// gap.json (hexsim.gap/1, CONTRACTS.md "Gap diagnosis"): the typed report serialised (report.cc).
#pragma once

#include <nlohmann/json.hpp>

#include "hexsim/gap/diagnose.h"

namespace hexsim::gap {

nlohmann::json ToJson(const GapReport& report);

}  // namespace hexsim::gap
