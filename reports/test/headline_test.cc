// Headlines state the result with intervals that stay non-negative.
#include "hexsim/reports/headline.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

#include <gtest/gtest.h>

#include "hexsim/common/statistics.h"
#include "hexsim/reports/batch_report.h"

namespace hexsim::reports {
namespace {

experiments::ComparisonGroup Group(const std::string& calibration, const std::vector<double>& yaw_max_deg,
                                   const std::vector<double>& cross_rms_m) {
  experiments::ComparisonGroup g;
  g.calibration = calibration;
  g.n = yaw_max_deg.size();
  g.metrics["yaw_error_deg.max"] = SummarizeNonNegative(yaw_max_deg);
  g.metrics["cross_track_m.rms"] = SummarizeNonNegative(cross_rms_m);
  return g;
}

std::string Joined(const std::vector<std::string>& sentences) {
  std::string s;
  for (const auto& x : sentences) s += x + "\n";
  return s;
}

TEST(CompareHeadline, GivenThreeCalibrationsWhenSummarisedThenTheBestIsNamedAgainstNoneAndTraditionalWithIntervals) {
  // Given
  experiments::Comparison c;
  c.mission = "climb_cruise_square";
  c.vehicle = "paper_hex";
  c.estimator = "eskf";
  c.groups = {Group("none", {10.0, 11.0, 12.0}, {7.0, 8.0, 9.0}), Group("traditional", {8.5, 9.0, 9.5}, {0.5, 1.5, 3.0}),
              Group("adaptive", {2.5, 3.0, 3.5}, {0.4, 1.0, 2.5})};
  // When
  const std::string h = Joined(CompareHeadline(c));
  // Then
  EXPECT_NE(h.find("climb_cruise_square flown by paper_hex (eskf estimate), 3 calibrations × 3 seeds."), std::string::npos) << h;
  EXPECT_NE(h.find("Lowest mean maximum yaw error: adaptive, 3.0° ["), std::string::npos) << h;
  EXPECT_NE(h.find("Against no calibration, adaptive cuts the maximum yaw error from 11.0° ["), std::string::npos) << h;
  EXPECT_NE(h.find("Against traditional, adaptive cuts the maximum yaw error from 9.0° ["), std::string::npos) << h;
  // Cross-track RMS of traditional and adaptive: skewed seeds, intervals clipped at 0 and overlapping.
  EXPECT_NE(h.find("[0.00*, "), std::string::npos) << h;
  EXPECT_NE(h.find("the intervals overlap: these seeds do not separate them"), std::string::npos) << h;
  EXPECT_NE(h.find("the intervals are apart"), std::string::npos) << h;
  EXPECT_EQ(h.find("[-"), std::string::npos) << "a negative interval end: " << h;
}

TEST(CompareHeadline, GivenOnlyUncalibratedRunsWhenSummarisedThenItSaysThereIsNothingToCompare) {
  experiments::Comparison c;
  c.groups = {Group("none", {10.0}, {7.0})};
  EXPECT_NE(Joined(CompareHeadline(c)).find("nothing to compare"), std::string::npos);
}

batch::RunRow Row(const std::string& calibration, uint64_t seed, double rms) {
  batch::RunPoint p;
  p.calibration = calibration;
  p.seed = seed;
  batch::RunRow r = batch::FailedRow(p, "completed", "", 0.0);
  r.metrics["cross_track_rms_m"] = rms;
  return r;
}

TEST(BatchHeadline, GivenTwoGroupsWhenSummarisedThenRunsOutcomeAndTheLowestAndHighestGroupAreStated) {
  // Given
  const auto groups = batch::AggregateRuns(
      {Row("none", 1, 1.0), Row("none", 2, 3.0), Row("adaptive", 1, 0.5), Row("adaptive", 2, 0.7)});
  // When
  const std::string h = Joined(BatchHeadline(groups));
  // Then
  EXPECT_NE(h.find("4 runs in 2 groups: 4 completed."), std::string::npos) << h;
  EXPECT_NE(h.find("Cross-track RMS is lowest in"), std::string::npos) << h;
  EXPECT_NE(h.find("0.60 m ["), std::string::npos) << h;
  EXPECT_NE(h.find("2.00 m [0.00*, "), std::string::npos) << h;
  EXPECT_EQ(h.find("[-"), std::string::npos) << h;
}

TEST(BatchReportHtml, GivenGroupsWhenWrittenThenThePageOpensWithTheHeadlineAndLinksTheFigure) {
  // Given
  const auto groups = batch::AggregateRuns({Row("none", 1, 1.0), Row("none", 2, 3.0)});
  const auto dir = std::filesystem::temp_directory_path() / ("hexsim_batch_html_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  // When
  ASSERT_TRUE(WriteBatchReportHtml(groups, "report.png", (dir / "report.html").string()).ok());
  // Then
  std::ifstream f(dir / "report.html");
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string html = ss.str();
  const size_t headline = html.find("class=\"headline\""), table = html.find("<table");
  ASSERT_NE(headline, std::string::npos);
  EXPECT_LT(headline, table);
  EXPECT_NE(html.find("2 runs in 1 group: 2 completed."), std::string::npos);
  EXPECT_NE(html.find("<img src=\"report.png\""), std::string::npos);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace hexsim::reports
