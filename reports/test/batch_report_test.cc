#include "hexsim/reports/batch_report.h"

#include <gtest/gtest.h>

namespace hexsim::reports {
namespace {

batch::RunRow Row(const std::string& calibration, uint64_t seed, double rms) {
  batch::RunPoint p;
  p.calibration = calibration;
  p.seed = seed;
  batch::RunRow r = batch::FailedRow(p, "completed", "", 0.0);
  r.metrics["cross_track_rms_m"] = rms;
  return r;
}

TEST(NumberedReportTable, GivenTwoGroupsThenEachGroupHeaderIsNumberedAndItsMetricLinesAreNot) {
  const auto groups = batch::AggregateRuns({Row("none", 1, 1.0), Row("none", 2, 3.0), Row("adaptive", 1, 0.5)});
  const std::string t = NumberedReportTable(groups);
  EXPECT_EQ(t.rfind("[1] ", 0), 0u);
  EXPECT_NE(t.find("\n[2] "), std::string::npos);
  EXPECT_EQ(t.find("[3] "), std::string::npos);
  EXPECT_NE(t.find("\n  cross_track_rms_m"), std::string::npos);
  // The none group: mean 2, std √2, interval 2 ± 12.7062 (t_{0.975,1}·√2/√2), clipped at 0 below
  // (a cross-track RMS is never negative).
  EXPECT_NE(t.find("[0*, 14.71]"), std::string::npos) << t;
}

}  // namespace
}  // namespace hexsim::reports
