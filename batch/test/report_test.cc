#include "hexsim/batch/report.h"

#include <cmath>

#include <gtest/gtest.h>

#include "hexsim/common/rng.h"

namespace hexsim::batch {
namespace {

TEST(StudentT975, GivenDegreesOfFreedomWhenLookedUpThenItMatchesTablesAndTendsToTheNormalQuantile) {
  EXPECT_NEAR(StudentT975(1), 12.706, 1e-3);
  EXPECT_NEAR(StudentT975(4), 2.776, 1e-3);
  EXPECT_NEAR(StudentT975(40), 2.021, 2e-3);    // table value 2.0211
  EXPECT_NEAR(StudentT975(100), 1.984, 2e-3);   // table value 1.9840
  EXPECT_NEAR(StudentT975(100000), 1.960, 1e-3);
}

TEST(ComputeStats, GivenNormalSamplesWhenTheIntervalIsComputedThenItCoversTheTrueMeanAbout95PercentOfTheTime) {
  RngStream rng(3, "ci_coverage");
  constexpr int kTrials = 4000;
  constexpr double kMean = 5.0, kStd = 2.0;
  int covered = 0;
  for (int t = 0; t < kTrials; ++t) {
    std::vector<double> v;
    v.reserve(5);
    for (int i = 0; i < 5; ++i) v.push_back(rng.Normal(kMean, kStd));
    const MetricStats s = ComputeStats(v);
    ASSERT_TRUE(s.ci95_lo && s.ci95_hi && s.std);
    covered += (*s.ci95_lo <= kMean && kMean <= *s.ci95_hi);
  }
  // Binomial(4000, 0.95): std 0.0034; 4 sigma.
  EXPECT_NEAR(static_cast<double>(covered) / kTrials, 0.95, 0.014);
}

TEST(ComputeStats, GivenOneOrNoValueWhenComputedThenThereIsNoSpreadOrInterval) {
  EXPECT_EQ(ComputeStats({}).n, 0u);
  const MetricStats one = ComputeStats({3.0});
  EXPECT_DOUBLE_EQ(one.mean, 3.0);
  EXPECT_FALSE(one.std.has_value());
  EXPECT_FALSE(one.ci95_lo.has_value());
  const MetricStats two = ComputeStats({1.0, 3.0});
  EXPECT_DOUBLE_EQ(two.mean, 2.0);
  EXPECT_DOUBLE_EQ(*two.std, std::sqrt(2.0));
  EXPECT_NEAR(*two.ci95_hi - 2.0, 12.706 * std::sqrt(2.0) / std::sqrt(2.0), 1e-3);
}

RunRow Row(const std::string& calibration, uint64_t seed, const std::string& status, double rms) {
  RunPoint p;
  p.calibration = calibration;
  p.seed = seed;
  RunRow r = FailedRow(p, status, "", 0.0);
  if (!IsFailure(status)) r.metrics["cross_track_rms_m"] = rms;
  return r;
}

TEST(AggregateRuns, GivenSeedsOfTwoConfigurationsWhenAggregatedThenSeedsGroupAndFailedRunsAreCountedNotAveraged) {
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
  EXPECT_EQ(adaptive.runs, 2u);
  EXPECT_DOUBLE_EQ(adaptive.metrics.at("cross_track_rms_m").mean, 0.6);
  EXPECT_FALSE(none.params.contains("seed"));
  const auto j = ReportJson(groups);
  EXPECT_EQ(j["schema"], "hexsim.batch_report/1");
  EXPECT_EQ(j["runs"], 5);
  EXPECT_NE(ReportTable(groups).find("cross_track_rms_m"), std::string::npos);
}

}  // namespace
}  // namespace hexsim::batch
