#include "hexsim/experiments/comparison.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "hexsim/experiments/compare.h"
#include "hexsim/experiments/ground_calibration.h"
#include "hexsim/experiments/point_runner.h"

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

// compare's typed path end to end: the first flight and the summary that reach the parent from the
// pool's forked worker are the ones flown in-process, value for value (the wall time aside).
TEST(RunComparison, GivenOneSeedWhenComparedThenTheFlightAndSummaryFromTheWorkerAreTheInProcessOnes) {
  CompareOptions o;
  o.request.duration_s = 20.0;
  o.request.seed = 3;
  o.calibrations = {"adaptive"};
  o.seeds = 1;
  const std::string dir =
      (std::filesystem::temp_directory_path() / ("hexsim_compare_typed_" + std::to_string(getpid()))).string();
  std::filesystem::remove_all(dir);
  auto got = RunComparison(o, dir);
  ASSERT_TRUE(got.ok()) << got.status().message();
  auto setup = sim::LoadRunSetup(o.request);
  ASSERT_TRUE(setup.ok()) << setup.status().message();
  auto want = FlyPoint(std::move(*setup), "adaptive");
  ASSERT_TRUE(want.ok()) << want.status().message();
  std::filesystem::remove_all(dir);

  ASSERT_EQ(got->comparison.runs.size(), 1u);
  nlohmann::json got_summary = sim::ToJson(got->comparison.runs[0].summary);
  nlohmann::json want_summary = sim::ToJson(want->summary);
  got_summary.erase("wall_s");
  want_summary.erase("wall_s");
  EXPECT_EQ(got_summary, want_summary);
  ASSERT_EQ(got->evidence.first_flights.size(), 1u);
  const logs::FlightLog& flight = got->evidence.first_flights[0].log;
  const logs::FlightLog& flown = want->log;
  EXPECT_EQ(flight.meta, flown.meta);
  ASSERT_EQ(flight.columns(), flown.columns());
  ASSERT_EQ(flight.rows(), flown.rows());
  ASSERT_GT(flown.rows(), 100u);
  size_t differing = 0;
  for (size_t c = 0; c < flown.columns().size(); ++c) {
    for (size_t i = 0; i < flown.rows(); ++i) {
      const double a = flight.At(i, c), b = flown.At(i, c);
      if (std::isnan(b) ? !std::isnan(a) : a != b) ++differing;
    }
  }
  EXPECT_EQ(differing, 0u);
}

}  // namespace
}  // namespace hexsim::experiments
