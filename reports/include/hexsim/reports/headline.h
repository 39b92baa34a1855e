// Headlines: the few sentences a report opens with, stating its result with 95 % intervals, so a
// reader learns it before studying a table. Plain text (the HTML writers escape it).
#pragma once

#include <string>
#include <vector>

#include "hexsim/batch/report.h"
#include "hexsim/experiments/comparison.h"

namespace hexsim::reports {

// E.g. "adaptive cuts the maximum yaw error from 11.4° [7.8, 15.0] with no calibration to 2.9°
// [0.4, 5.5], and the cross-track RMS from 8.15 m [5.9, 10.4] to 1.23 m [0.00*, 2.84]. …". The best
// calibration is the one with the lowest mean maximum yaw error; it is compared with `none` and with
// `traditional` where those were flown, and the sentence says when the intervals overlap.
std::vector<std::string> CompareHeadline(const experiments::Comparison& comparison);

// The batch's result: runs and their outcome, and the groups with the lowest and highest mean
// cross-track RMS with their intervals (or what is known when no group has an interval).
std::vector<std::string> BatchHeadline(const std::vector<batch::GroupReport>& groups);

}  // namespace hexsim::reports
