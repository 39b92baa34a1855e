// The comparison report: report.html with its PNG figures beside it (relative links).
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "hexsim/common/status.h"

namespace hexsim::app {

// Writes report.html and the figures for a hexsim.comparison/1 document into out_dir (which also
// holds <calibration>/seed_<n>/log.csv for each run).
Status WriteCompareReport(const nlohmann::json& comparison, const std::string& out_dir);

}  // namespace hexsim::app
