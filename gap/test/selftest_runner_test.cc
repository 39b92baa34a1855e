// The selftest's trials are independent: how a runner orders them does not change the result.
#include <algorithm>
#include <string>

#include <gtest/gtest.h>

#include "hexsim/gap/selftest.h"

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
  TrialRunner reverse = [&](size_t n, const TrialFn& one) -> Result<std::vector<nlohmann::json>> {
    std::vector<nlohmann::json> out(n);
    for (size_t i = n; i-- > 0;) {
      auto r = one(i);
      if (!r.ok()) return r.status();
      out[i] = nlohmann::json::parse(r->dump());  // as a forked worker passes it back
      ran.push_back(i);
    }
    return out;
  };
  auto reversed = RunSelftest(o, nullptr, reverse);
  ASSERT_TRUE(reversed.ok()) << reversed.status().message();
  EXPECT_EQ(ran.size(), 5u + 6u);  // five classes (beyond_library among them) and the six-magnitude threshold sweep
  EXPECT_EQ(in_order->json.dump(), reversed->json.dump());
  EXPECT_EQ(in_order->table, reversed->table);
  // The forms beyond the library's names are a class of their own, judged by what names them right.
  bool beyond = false;
  for (const auto& c : in_order->json["classes"]) beyond = beyond || (c["class"] == "beyond_library" && c.contains("judged_right_rate"));
  EXPECT_TRUE(beyond);
  EXPECT_TRUE(in_order->json["targets"].contains("beyond_library_judged_right_ge_0.85"));
  // The lagged power-law form (the class's first trial) is judged by its lag too: named current_lag,
  // its lag's interval holding the truth.
  for (const auto& c : in_order->json["classes"]) {
    if (c["class"] != "beyond_library") continue;
    ASSERT_TRUE(c["per_family"].contains("current_power_lag")) << c.dump();
    EXPECT_TRUE(c["per_family"]["current_power_lag"].contains("lag_covered")) << c.dump();
    EXPECT_TRUE(c["per_family"]["current_power_lag"].contains("named_current_lag")) << c.dump();
  }
  EXPECT_NE(in_order->table.find("named current_lag"), std::string::npos) << in_order->table;
}

}  // namespace
}  // namespace hexsim::gap
