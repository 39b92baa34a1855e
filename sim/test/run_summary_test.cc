#include "hexsim/sim/run_summary.h"

#include <gtest/gtest.h>

namespace hexsim::sim {
namespace {

RunSummary Example() {
  RunSummary s;
  s.status = RunStatus::kDiverged;
  s.reason = "non-finite attitude at t = 3.000 s";
  s.mission = "square";
  s.seed = 18446744073709551615ULL;  // the largest seed survives the round trip
  s.cross_track_m = {2.5, 0.1 + 0.2};
  s.current_max_A = 53.25;
  s.waypoints = {{1, 0.31, 12.5}, {2, 0.27, 30.0}};
  return s;
}

TEST(RunSummary, GivenASummaryWhenWrittenAndReadBackThenEveryFieldIsTheSameBitForBit) {
  const RunSummary s = Example();
  const nlohmann::json j = ToJson(s);
  EXPECT_EQ(j["schema"], "hexsim.summary/1");
  EXPECT_EQ(j["status"], "diverged");
  EXPECT_TRUE(j["mission_time_s"].is_null());
  auto back = RunSummaryFromJson(nlohmann::json::parse(j.dump(2)), "summary.json");
  ASSERT_TRUE(back.ok()) << back.status().message();
  EXPECT_EQ(ToJson(*back).dump(), j.dump());
  EXPECT_EQ(back->seed, s.seed);
  EXPECT_EQ(back->cross_track_m.rms, 0.1 + 0.2);
  EXPECT_FALSE(back->mission_time_s.has_value());
  ASSERT_EQ(back->waypoints.size(), 2u);
  EXPECT_EQ(back->waypoints[1].index, 2);
}

TEST(RunSummary, GivenAMissingOrMistypedKeyWhenReadThenItIsBadInputNamingTheKey) {
  nlohmann::json j = ToJson(Example());
  j["cross_track_m"].erase("rms");
  auto missing = RunSummaryFromJson(j, "runs/x/summary.json");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().code(), StatusCode::kBadInput);
  EXPECT_EQ(missing.status().message(), "runs/x/summary.json: cross_track_m/rms: missing");
  j = ToJson(Example());
  j["energy_Wh"] = "a lot";
  EXPECT_NE(RunSummaryFromJson(j, "s.json").status().message().find("energy_Wh: wrong type"), std::string::npos);
  j = ToJson(Example());
  j["status"] = "finished";
  EXPECT_FALSE(RunSummaryFromJson(j, "s.json").ok());
}

}  // namespace
}  // namespace hexsim::sim
