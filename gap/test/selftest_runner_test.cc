// The selftest's trials are independent: how a runner orders them does not change the result.
#include <algorithm>
#include <limits>
#include <variant>
#include <string>

#include <gtest/gtest.h>

#include "hexsim/gap/selftest.h"
#include "hexsim/gap/selftest_json.h"

namespace hexsim::gap {
namespace {

TEST(GapSelftestRunner, GivenOneTrialPerClass_WhenTheTrialsRunInReverseOrderThroughARunner_ThenTheJsonIsTheSameAsInOrder) {
  SelftestOptions o;
  o.trials = 1;
  o.threshold_trials = 1;
  o.diagnose.timing_scan = false;  // cheaper: this checks the bookkeeping, not the metrics
  o.diagnose.bootstrap_samples = 20;
  auto in_order = RunSelftest(o);
  ASSERT_TRUE(in_order.ok()) << in_order.status().message();
  std::vector<size_t> ran;
  TrialRunner reverse = [&](size_t n, const TrialFn& one) -> Result<std::vector<TrialRecord>> {
    std::vector<TrialRecord> out(n);
    for (size_t i = n; i-- > 0;) {
      auto r = one(i);
      if (!r.ok()) return r.status();
      // As a forked worker passes it back: the record as JSON text, read back typed.
      auto back = TrialRecordFromJson(nlohmann::json::parse(ToJson(*r).dump()));
      if (!back.ok()) return back.status();
      out[i] = std::move(*back);
      ran.push_back(i);
    }
    return out;
  };
  auto reversed = RunSelftest(o, nullptr, reverse);
  ASSERT_TRUE(reversed.ok()) << reversed.status().message();
  EXPECT_EQ(ran.size(), 5u + 6u);  // five classes (beyond_library among them) and the six-magnitude threshold sweep
  const nlohmann::json json = ToJson(*in_order);
  EXPECT_EQ(json.dump(), ToJson(*reversed).dump());
  EXPECT_EQ(in_order->table, reversed->table);
  // The forms beyond the library's names are a class of their own, judged by what names them right.
  bool beyond = false;
  for (const auto& c : json["classes"]) beyond = beyond || (c["class"] == "beyond_library" && c.contains("judged_right_rate"));
  EXPECT_TRUE(beyond);
  EXPECT_TRUE(json["targets"].contains("beyond_library_judged_right_ge_0.85"));
  // The lagged power-law form (the class's first trial) is judged by its lag too: named current_lag,
  // its lag's interval holding the truth.
  for (const auto& c : json["classes"]) {
    if (c["class"] != "beyond_library") continue;
    ASSERT_TRUE(c["per_family"].contains("current_power_lag")) << c.dump();
    EXPECT_TRUE(c["per_family"]["current_power_lag"].contains("lag_covered")) << c.dump();
    EXPECT_TRUE(c["per_family"]["current_power_lag"].contains("named_current_lag")) << c.dump();
  }
  EXPECT_NE(in_order->table.find("named current_lag"), std::string::npos) << in_order->table;
}

// A record crosses a process boundary as JSON: every field, the optional ones and a non-finite
// interval end (written as null) among them, comes back as it went.
TEST(GapSelftestRunner, GivenARecordWithEveryField_WhenWrittenAndReadBack_ThenItsJsonIsUnchangedAndItsLabelsAreTyped) {
  ClassTrialRecord r;
  r.family = "current_power_lag";
  r.injected = {{"axis_scale_error", Effect::kScaleError}, {"current_exponent", Effect::kNone}};
  r.true_magnitude = {0.05, 0.4};
  r.verdict = "scale_error";
  r.gap_detected = true;
  r.heldout_shrink = 0.7;
  r.explained_share = 0.6;
  r.selected = "scale_error+current_lag";
  r.dynamics_detected = false;
  r.left_reported = true;
  r.not_confident = true;
  r.named_right = false;
  r.judged_right = true;
  r.true_lag_s = 0.5;
  r.lag_fit = LagFit{0.45, {0.3, std::numeric_limits<double>::infinity()}, true, true, false, true};
  r.reported = {{Effect::kScaleError, 0.049, {0.04, 0.06}, 0.55, true}};
  r.true_share = 0.55;
  r.covered = true;
  const nlohmann::json j = ToJson(TrialRecord(r));
  EXPECT_EQ(j["labels"], (nlohmann::json{"scale_error", "current_exponent"}));
  const nlohmann::json text = nlohmann::json::parse(j.dump());
  EXPECT_TRUE(text["lag_fit"]["ci95"][1].is_null());
  auto back = TrialRecordFromJson(text);
  ASSERT_TRUE(back.ok()) << back.status().message();
  ASSERT_TRUE(std::holds_alternative<ClassTrialRecord>(*back));
  const auto& b = std::get<ClassTrialRecord>(*back);
  ASSERT_EQ(b.injected.size(), 2u);
  EXPECT_EQ(b.injected[0].label, Effect::kScaleError);
  EXPECT_EQ(b.injected[1].label, Effect::kNone);
  EXPECT_EQ(b.injected[1].name, "current_exponent");
  ASSERT_EQ(b.reported.size(), 1u);
  EXPECT_EQ(b.reported[0].effect, Effect::kScaleError);
  EXPECT_EQ(ToJson(*back).dump(), j.dump());
  const ThresholdTrialRecord t{0.02, true, "current_hard_iron"};
  auto t_back = TrialRecordFromJson(nlohmann::json::parse(ToJson(TrialRecord(t)).dump()));
  ASSERT_TRUE(t_back.ok());
  ASSERT_TRUE(std::holds_alternative<ThresholdTrialRecord>(*t_back));
  EXPECT_EQ(std::get<ThresholdTrialRecord>(*t_back).magnitude_uT_per_A, 0.02);
  EXPECT_TRUE(std::get<ThresholdTrialRecord>(*t_back).flagged);
  // Not a record: one line naming what is wrong, no exception.
  EXPECT_FALSE(TrialRecordFromJson(nlohmann::json{{"verdict", "none"}}).ok());
}

}  // namespace
}  // namespace hexsim::gap
