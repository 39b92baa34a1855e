// The batch report (`hexsim batch-report`): per group of replicates, each figure's mean, sample
// standard deviation and 95 % interval of the mean (batch/report.h aggregates them), as a text table
// and as report.png. Draws what the aggregation computed; computes nothing itself.
#pragma once

#include <string>
#include <vector>

#include "hexsim/batch/report.h"
#include "hexsim/common/status.h"

namespace hexsim::reports {

// A fixed-width text table: one block per group, one line per metric.
std::string ReportTable(const std::vector<batch::GroupReport>& groups);
// The same with the groups numbered "[k] " as on the figure's x axis.
std::string NumberedReportTable(const std::vector<batch::GroupReport>& groups);
// report.png: mean and 95 % interval per group for cross-track RMS, yaw RMS, energy and mean current.
Status WriteBatchReportFigure(const std::vector<batch::GroupReport>& groups, const std::string& path);
// report.html beside report.json: the headline (headline.h), one table row per group with each figure's
// mean and 95 % interval, and report.png when `figure` names it (relative link). batch_report_html.cc.
Status WriteBatchReportHtml(const std::vector<batch::GroupReport>& groups, const std::string& figure,
                            const std::string& path);

}  // namespace hexsim::reports
