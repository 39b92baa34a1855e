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

// The dynamics channel's one-effect target is the median explained share of the true effect (as the
// compasses'), not the held-out shrink: a set of trials whose true effect explains 70 % of the
// residual above the floor while the RMS about zero shrinks 30 % meets it, both printed.
TEST(GapSelftestRunner, GivenDynamicsTrialsExplainingMostAboveTheFloor_WhenSummarised_ThenTheShareTargetIsMetAndBothArePrinted) {
  SelftestOptions o;
  o.profile = "ideal";
  o.trials = 2;
  o.threshold_trials = 0;
  // Classes in trial order: clean, one_effect, two_effects, out_of_library, dynamics_one_effect.
  TrialRunner made_up = [](size_t n, const TrialFn&) -> Result<std::vector<TrialRecord>> {
    std::vector<TrialRecord> out;
    for (size_t i = 0; i < n; ++i) {
      ClassTrialRecord r;
      const size_t cls = i / 2;
      if (cls == 1 || cls == 2) r.injected = {{"misalignment", Effect::kMisalignment}, {"wind", Effect::kWind}};
      if (cls == 4) {
        r.injected = {{"motor_time_constant", Effect::kMotorTimeConstant}};
        r.verdict = "motor_time_constant";
        r.gap_detected = true;
        r.heldout_shrink = 0.3;
        r.true_share = 0.7;
        r.covered = true;
      }
      out.emplace_back(std::move(r));
    }
    return out;
  };
  auto res = RunSelftest(o, nullptr, made_up);
  ASSERT_TRUE(res.ok()) << res.status().message();
  ASSERT_TRUE(res->dynamics_targets.has_value());
  EXPECT_EQ(res->dynamics_targets->count("median_shrink_ge_0.50"), 0u);
  ASSERT_EQ(res->dynamics_targets->count("median_explained_share_ge_0.50"), 1u);
  EXPECT_TRUE(res->dynamics_targets->at("median_explained_share_ge_0.50"));
  EXPECT_TRUE(res->dynamics_targets->at("coverage_ge_0.90"));
  EXPECT_NE(res->table.find("median explained share of the true effect   70 % (>= 50 %), median held-out shrink   30 %"),
            std::string::npos)
      << res->table;
  const nlohmann::json j = ToJson(*res);
  for (const auto& c : j["classes"]) {
    if (c["class"] == "dynamics_one_effect") {
      EXPECT_DOUBLE_EQ(c["median_explained_share"].get<double>(), 0.7) << c.dump();
    }
  }
}

}  // namespace
}  // namespace hexsim::gap
