#include "hexsim/batch/report.h"

#include <gtest/gtest.h>

namespace hexsim::batch {
namespace {

RunRow Row(const std::string& calibration, uint64_t seed, const std::string& status, double rms) {
  RunPoint p;
  p.calibration = calibration;
  p.seed = seed;
  RunRow r = FailedRow(p, status, "", 0.0);
  if (!IsFailure(status)) r.metrics["cross_track_rms_m"] = rms;
  return r;
}

// A run that hit the time cap (not_completed) kept flying and burning energy: its figures are not
// the mission's. It used to be averaged in (a 360-run batch's energy mean 41.3 Wh against ~23 Wh).
TEST(AggregateRuns, GivenSeedsOfTwoConfigurationsWhenAggregatedThenSeedsGroupAndUnfinishedRunsAreListedNotAveraged) {
  const std::vector<RunRow> rows = {Row("none", 1, "completed", 1.0), Row("adaptive", 1, "completed", 0.5),
                                    Row("none", 2, "completed", 3.0), Row("none", 3, "crashed", 0.0),
                                    Row("adaptive", 2, "not_completed", 0.7)};
  const auto groups = AggregateRuns(rows);
  ASSERT_EQ(groups.size(), 2u);
  const GroupReport& none = groups[0].label.find(" none") != std::string::npos ? groups[0] : groups[1];
  const GroupReport& adaptive = &none == &groups[0] ? groups[1] : groups[0];
  EXPECT_EQ(none.runs, 3u);
  EXPECT_EQ(none.status_counts.at("crashed"), 1u);
  EXPECT_EQ(none.metrics.at("cross_track_rms_m").n, 2u);
  EXPECT_DOUBLE_EQ(none.metrics.at("cross_track_rms_m").mean, 2.0);
  EXPECT_EQ(none.finished, 2u);
  ASSERT_EQ(none.unfinished.size(), 1u);
  EXPECT_EQ(none.unfinished[0].seed, 3u);
  EXPECT_EQ(none.unfinished[0].status, "crashed");
  EXPECT_EQ(adaptive.runs, 2u);
  EXPECT_EQ(adaptive.finished, 1u);
  EXPECT_EQ(adaptive.metrics.at("cross_track_rms_m").n, 1u);
  EXPECT_DOUBLE_EQ(adaptive.metrics.at("cross_track_rms_m").mean, 0.5);
  ASSERT_EQ(adaptive.unfinished.size(), 1u);
  EXPECT_EQ(adaptive.unfinished[0].seed, 2u);
  EXPECT_EQ(adaptive.unfinished[0].status, "not_completed");
  EXPECT_FALSE(none.params.contains("seed"));
  const auto j = ReportJson(groups);
  EXPECT_EQ(j["schema"], "hexsim.batch_report/1");
  EXPECT_EQ(j["runs"], 5);
  for (const auto& g : j["groups"]) {
    EXPECT_EQ(g["finished"].get<size_t>() + g["unfinished"].size(), g["runs"].get<size_t>());
  }
}

}  // namespace
}  // namespace hexsim::batch
