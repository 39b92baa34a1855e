#include "hexsim/experiments/comparison.h"

#include <gtest/gtest.h>

#include "hexsim/experiments/ground_calibration.h"

namespace hexsim::experiments {
namespace {

sim::RunSummary Summary(double yaw_max_deg, double xtrack_rms_m) {
  sim::RunSummary s;
  s.status = sim::RunStatus::kCompleted;
  s.yaw_error_deg = {yaw_max_deg, 0.5 * yaw_max_deg};
  s.cross_track_m = {2 * xtrack_rms_m, xtrack_rms_m};
  s.energy_Wh = 3.0;
  return s;
}

TEST(GroundSessionSeed, GivenAFlightSeedThenTheGroundSessionHasItsOwnSeedByTheOneFormula) {
  EXPECT_EQ(GroundSessionSeed(1), 1000020u);  // 1·1000003 + 17
  EXPECT_NE(GroundSessionSeed(2), GroundSessionSeed(1));
  EXPECT_NE(GroundSessionSeed(1), kTable1TurnSeed);
}

TEST(MakeCalibration, GivenNoneThenThereIsNoCompensatorAndGivenAnUnknownNameThenItIsBadInput) {
  auto none = MakeCalibration("none", std::vector<magnetics::MagSample>{});
  ASSERT_TRUE(none.ok());
  EXPECT_EQ(none->compensator, nullptr);
  EXPECT_EQ(none->name, "none");
  auto bad = MakeCalibration("no_such_method", std::vector<magnetics::MagSample>{});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().code(), StatusCode::kBadInput);
  EXPECT_NE(bad.status().message().find("no_such_method"), std::string::npos);
  EXPECT_TRUE(IsCalibrationMethod("adaptive"));
  EXPECT_FALSE(IsCalibrationMethod("calib.yaml"));
}

TEST(GroupMetrics, GivenTwoSeedsThenEachFigureHasItsMeanStdAndStudentInterval) {
  const auto m = GroupMetrics({Summary(2.0, 1.0), Summary(4.0, 3.0)});
  const SampleStats& yaw = m.at("yaw_error_deg.max");
  EXPECT_EQ(yaw.n, 2u);
  EXPECT_DOUBLE_EQ(yaw.mean, 3.0);
  EXPECT_DOUBLE_EQ(*yaw.std, std::sqrt(2.0));
  EXPECT_NEAR(*yaw.ci95_hi - 3.0, 12.7062 * 1.0, 1e-4);  // t_{0.975,1}·s/√2 with s = √2
  // 3 − 12.7 < 0: a yaw error magnitude's interval is clipped at 0, and says so.
  EXPECT_EQ(*yaw.ci95_lo, 0.0);
  EXPECT_TRUE(yaw.ci95_clipped);
  EXPECT_EQ(m.count("mission_time_s"), 0u);  // no run landed: not a figure of the group
}

TEST(ComparisonToJson, GivenOneSeedThenTheContractKeysAreWrittenAndTheIntervalCollapsesOntoTheMean) {
  Comparison c;
  c.mission = "square";
  c.runs.push_back({"none", 7, Summary(3.0, 1.5), "none/seed_7"});
  c.groups.push_back({"none", 1, GroupMetrics({c.runs[0].summary})});
  c.heading_error.control_u = {0, 200};
  c.heading_error.rows.push_back({"uncorrected", "none", {10, 11}, {5, 6}, {0.5, 30}});
  const nlohmann::json j = ToJson(c);
  EXPECT_EQ(j["schema"], "hexsim.comparison/1");
  EXPECT_EQ(j["runs"][0]["seed"], 7);
  const auto& yaw = j["groups"][0]["metrics"]["yaw_error_deg.max"];
  EXPECT_EQ(yaw["std"], 0.0);
  EXPECT_EQ(yaw["ci95"][0], 3.0);
  EXPECT_EQ(yaw["ci95"][1], 3.0);
  EXPECT_EQ(j["heading_error"]["schema"], "hexsim.heading_error/1");
  const std::string table = ComparisonTable(c);
  EXPECT_NE(table.find("uncorrected"), std::string::npos);
  EXPECT_NE(table.find("3.00 ± 0.00"), std::string::npos);
}

}  // namespace
}  // namespace hexsim::experiments
