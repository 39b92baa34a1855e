// The sensor's calibration beside a current field. current_soft_iron beside a current field the
// vehicle file does not model (gap diagnose without --sim: the shipped vehicle's wiring field is not
// subtracted, so the log holds a plain current field beside the soft iron): the soft iron's size is
// the part that field cannot describe. A static per-axis scale beside a dominant current field: the
// scale's test alone is over a residual that holds the current field whole; whether it joins is
// decided over the model (ScaleMayJoin).
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "support/gap_fixtures.h"

#include "hexsim/gap/diagnose.h"

namespace hexsim::gap {
namespace {

const EffectShare* BesideFieldEffect(const ChannelResult& c, const std::string& effect) {
  for (const EffectShare& e : c.effects) {
    if (e.effect == effect) return &e;
  }
  return nullptr;
}

double BesideFieldTruth(const gaptest::Flown& f, const std::string& effect) {
  for (size_t i = 0; i < f.trial.injections.size(); ++i) {
    if (f.trial.injections[i].effect == effect) return f.trial.true_magnitude[i];
  }
  return -1.0;
}

// The effect's 95 % interval, widened by a tenth of its width each side (scripts/withheld_sim's
// rule), holds the planted size of `injected`.
void ExpectHoldsPlanted(const gaptest::Flown& f, const GapReport& rep, const EffectShare& e, const std::string& injected) {
  const double truth = BesideFieldTruth(f, injected);
  const double w = 0.1 * (e.ci95.hi - e.ci95.lo);
  EXPECT_LE(e.ci95.lo - w, truth) << Summary(rep);
  EXPECT_GE(e.ci95.hi + w, truth) << Summary(rep);
}

struct SoftCase {
  double soft_per_A;    // Frobenius norm of the planted dK/dI
  double field_uT_per_A;  // the unmodelled current field beside it
  uint64_t seed;
};

class GapSoftIronBesideField : public ::testing::TestWithParam<SoftCase> {};

// Given a current soft iron of 0.004-0.008 /A beside an unmodelled current field of 1 mG/A, too small
// to join it as an effect of its own, when diagnosed, then current_soft_iron is an effect and its
// interval, widened by a tenth of its width each side (scripts/withheld_sim's rule), holds the
// planted size. Fitted alone, its down-field column takes the current field (E·h̄ is a current hard
// iron): these three read 0.0044 [0.0041, 0.0046], 0.0035 [0.0031, 0.0039] and 0.0072 [0.0067,
// 0.0077] /A for 0.0039, 0.0040 and 0.0080 planted; in scripts/withheld_sim (no --sim, a shipped
// vehicle's 2.5-4 mG/A wiring field beside it) 0.0087-0.011 /A for 0.0058-0.0081 /A.
TEST_P(GapSoftIronBesideField, GivenASoftIronBesideAnUnmodelledCurrentField_WhenDiagnosed_ThenItsSizeIsItsOwn) {
  const SoftCase& c = GetParam();
  gaptest::Flown f = gaptest::FlyInjected({{"current_soft_iron", c.soft_per_A}, {"current_hard_iron", c.field_uT_per_A}},
                                          c.seed, "soft_iron_field", "selftest_flight");
  auto rep = Diagnose(f.log, f.trial.configured, gaptest::IdealOptions());
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr);
  const EffectShare* soft = BesideFieldEffect(*mag2, "current_soft_iron");
  ASSERT_NE(soft, nullptr) << Summary(*rep);
  ExpectHoldsPlanted(f, *rep, *soft, "current_soft_iron");
}

INSTANTIATE_TEST_SUITE_P(Sizes, GapSoftIronBesideField,
                         ::testing::Values(SoftCase{0.004, 0.1, 2501}, SoftCase{0.004, 0.1, 2502},
                                           SoftCase{0.008, 0.1, 2502}));

struct ScaleCase {
  double scale;           // one horizontal axis' gain − 1
  double field_uT_per_A;  // the current field beside it
  uint64_t seed;
};

class GapScaleBesideField : public ::testing::TestWithParam<ScaleCase> {};

// Given a 3-4 % gain on one horizontal axis beside a 3-5 mG/A current field, when diagnosed, then
// both are effects and the scale's interval, widened by a tenth of its width each side
// (scripts/withheld_sim's rule), holds the planted gain. Refused alone for its significance (the
// field's unmodelled structure in its variance), these three scales were not in the effects, and the
// current field's interval was five to ten times as wide (it absorbed the gain's part).
TEST_P(GapScaleBesideField, GivenAnAxisScaleBesideACurrentField_WhenDiagnosed_ThenBothAreEffects) {
  const ScaleCase& c = GetParam();
  gaptest::Flown f = gaptest::FlyInjected({{"axis_scale_error", c.scale}, {"current_hard_iron", c.field_uT_per_A}}, c.seed,
                                          "scale_beside_field", "selftest_flight");
  auto rep = Diagnose(f.log, f.trial.configured, gaptest::IdealOptions());
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr);
  ASSERT_NE(BesideFieldEffect(*mag2, "current_hard_iron"), nullptr) << Summary(*rep);
  const EffectShare* scale = BesideFieldEffect(*mag2, "scale_error");
  ASSERT_NE(scale, nullptr) << Summary(*rep);
  ExpectHoldsPlanted(f, *rep, *scale, "axis_scale_error");
}

INSTANTIATE_TEST_SUITE_P(Sizes, GapScaleBesideField,
                         ::testing::Values(ScaleCase{0.03, 0.3, 2603}, ScaleCase{0.03, 0.5, 2602},
                                           ScaleCase{0.04, 0.5, 2603}));

}  // namespace
}  // namespace hexsim::gap
