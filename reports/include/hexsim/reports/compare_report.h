// The comparison report: report.html with its PNG figures beside it (relative links) and
// heading_residuals.csv, drawn from the comparison and the evidence the experiment gathered
// (experiments/compare.h). It computes no result of its own: every number shown was computed by
// the experiment that flew the runs.
#pragma once

#include <string>

#include "hexsim/common/status.h"
#include "hexsim/experiments/compare.h"

namespace hexsim::reports {

Status WriteCompareReport(const experiments::Comparison& comparison, const experiments::CompareEvidence& evidence,
                          const std::string& out_dir);

}  // namespace hexsim::reports
