// The typed effect registry (effects.h): one row per effect, its physical range in the plausibility
// table, and every effect a diagnosis reports is registered with the unit the registry gives.
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "hexsim/common/plausibility.h"
#include "hexsim/gap/diagnose.h"
#include "hexsim/gap/effects.h"
#include "support/gap_fixtures.h"

namespace hexsim::gap {
namespace {

TEST(GapEffectRegistry, GivenTheRegistry_ThenRowsFollowTheEnumNamesAreUniqueAndRangesExist) {
  std::set<std::string> names;
  for (size_t i = 0; i < Effects().size(); ++i) {
    const EffectInfo& e = Effects()[i];
    EXPECT_EQ(static_cast<size_t>(e.id), i) << e.name;
    EXPECT_EQ(EffectFromName(e.name), e.id) << e.name;
    if (e.id == Effect::kNone) continue;
    EXPECT_TRUE(names.insert(e.name).second) << "two rows named " << e.name;
    if (*e.range_key != '\0') {
      EXPECT_NE(plausibility::FindRange(e.range_key), nullptr) << e.name << ": no range " << e.range_key;
    }
  }
  EXPECT_EQ(EffectFromName("current_hard_iron+latency"), Effect::kNone);
  EXPECT_TRUE(DrivenByCurrent(Effect::kThrottleHardIron));
  EXPECT_TRUE(DrivenByCurrent(Effect::kCurrentLag));
  EXPECT_FALSE(DrivenByCurrent(Effect::kScaleError));
  EXPECT_FALSE(Info(Effect::kCurrentSoftIron).compensable);
}

// Given a diagnosed flight with a withheld current field and latency, then every candidate and
// effect it reports carries its registered id, the registry's name, and (where the registry fixes
// one) the registry's unit.
TEST(GapEffectRegistry, GivenADiagnosis_WhenItsResultsAreRead_ThenEveryEffectIsRegistered) {
  gaptest::Flown f = gaptest::FlyInjected({{"current_hard_iron", 0.4}}, 3203, "effect_registry");
  auto rep = Diagnose(f.log, f.trial.configured);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  int checked = 0;
  for (const ChannelResult& ch : rep->channels) {
    for (const CandidateResult& k : ch.candidates) {
      ASSERT_NE(k.id, Effect::kNone) << ch.channel << ": " << k.effect << " is not registered";
      EXPECT_EQ(k.effect, Info(k.id).name);
      if (*Info(k.id).unit != '\0') {
        EXPECT_EQ(k.magnitude_unit, Info(k.id).unit) << k.effect;
      }
      ++checked;
    }
    for (const EffectShare& e : ch.effects) EXPECT_EQ(e.effect, Info(e.id).name) << ch.channel;
  }
  EXPECT_GT(checked, 10);
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr);
  ASSERT_FALSE(mag2->effects.empty()) << Summary(*rep);
  EXPECT_EQ(mag2->effects.front().id, Effect::kCurrentHardIron) << Summary(*rep);
}

}  // namespace
}  // namespace hexsim::gap
