// A static per-axis scale is a calibration error (scale_error with its size), not a current effect,
// alone and beside a current field (issue 29 item 4: decided with the current's variation).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include <gtest/gtest.h>

#include "../src/selftest_real.h"
#include "support/gap_fixtures.h"

#include "hexsim/common/rng.h"

#include "hexsim/gap/diagnose.h"
#include "hexsim/gap/effects.h"
#include "hexsim/logs/flight_log.h"

namespace hexsim::gap {
namespace {

using gaptest::InEffects;

bool AnyCurrentEffect(const ChannelResult& c) {
  for (const EffectShare& e : c.effects) {
    if (DrivenByCurrent(e.id)) return true;
  }
  return false;
}

// The chip's z gain: everything mag2 reads on z, (1 + s) times.
void ScaleMag2Z(double s, logs::FlightLog* log) {
  const size_t cz = static_cast<size_t>(log->ColumnIndex("mag2_z_uT"));
  for (double& m : log->MutableColumn(cz)) m = std::isfinite(m) ? (1.0 + s) * m : m;
}

// Given the compass's vertical axis reading 12 % large, when diagnosed, then it is scale_error with
// the vertical gain in its interval (the flight's tilt turns the horizontal field through z), and no
// current effect: the tilt a copter takes to fly fast is not the current that flies it.
TEST(GapScaleFamily, GivenTheVerticalAxisReadingLarge_WhenDiagnosed_ThenItIsAScaleErrorWithItsSize) {
  gaptest::Flown f = gaptest::FlyInjected({}, 2111, "scale_family", "selftest_flight");
  constexpr double kGain = 0.12;
  ScaleMag2Z(kGain, &f.log);
  DiagnoseOptions o;
  o.channels = {"mag2"};
  auto rep = Diagnose(f.log, f.trial.configured, o);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr);
  EXPECT_EQ(mag2->verdict, "scale_error") << Summary(*rep);
  EXPECT_FALSE(AnyCurrentEffect(*mag2)) << Summary(*rep);
  const CandidateResult* s = gaptest::FindCandidate(*mag2, "scale_error");
  ASSERT_NE(s, nullptr) << Summary(*rep);
  ASSERT_TRUE(s->params.count("scale_z_minus_1")) << Summary(*rep);
  EXPECT_NEAR(s->params.at("scale_z_minus_1"), kGain, 0.3 * kGain) << Summary(*rep);
  EXPECT_LE(s->magnitude_ci95[0], kGain) << Summary(*rep);
  EXPECT_GE(s->magnitude_ci95[1], kGain) << Summary(*rep);
}

// One horizontal axis reading 10 % large beside a 0.3 µT/A current field, flown with `seed`: both in
// effects, the gain's spread in its interval (the replay's 5 % beside it, as effects_test.cc), and no
// current_soft_iron.
void ExpectScaleBesideCurrentField(uint64_t seed) {
  gaptest::Flown f = gaptest::FlyInjected({{"axis_scale_error", 0.10}, {"current_hard_iron", 0.3}}, seed, "scale_family",
                                          "selftest_flight");
  DiagnoseOptions o;
  o.channels = {"mag2"};
  auto rep = Diagnose(f.log, f.trial.configured, o);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr);
  EXPECT_TRUE(InEffects(*mag2, "scale_error")) << Summary(*rep);
  EXPECT_TRUE(InEffects(*mag2, "current_hard_iron")) << Summary(*rep);
  EXPECT_FALSE(InEffects(*mag2, "current_soft_iron")) << Summary(*rep);
  for (const EffectShare& e : mag2->effects) {
    if (e.effect != "scale_error") continue;
    EXPECT_LE(e.ci95.lo - 0.05 * e.magnitude, 0.10) << Summary(*rep);
    EXPECT_GE(e.ci95.hi + 0.05 * e.magnitude, 0.10) << Summary(*rep);
  }
}

// Given one horizontal axis reading large beside a current field, when diagnosed, then both are in
// effects and the static gain is not read as current_soft_iron: its regressor I·h is Ī·h, a constant
// matrix, plus a down-field column I·B_D that is the current field (this flight read
// current_soft_iron 98 % alone while its partial test was over a constant matrix only).
TEST(GapScaleFamily, GivenAnAxisScaleBesideACurrentField_WhenDiagnosed_ThenBothAreNamedAndNoCurrentSoftIron) {
  ExpectScaleBesideCurrentField(2112);
}

// Given the same beside a current field the scale family does not hold, when diagnosed, then the
// vertical gain the family alone fits is not taken where fitting the current's field beside it moves
// it (the tilt a copter takes to fly fast carries the current's field into the vertical gain: here
// -0.15 for a true -0.05, a spread of 0.20, outside the physical range, and scale_error went missing).
TEST(GapScaleFamily, GivenAnAxisScaleAndAnUnmodelledCurrentField_WhenDiagnosed_ThenTheVerticalGainDoesNotTakeTheCurrent) {
  ExpectScaleBesideCurrentField(2113);
}

// Given the vertical axis reading 10 % small beside a current field the vehicle file does not model,
// when diagnosed, then the scale family reads the vertical gain it has beside that field: the tilt a
// copter takes to fly fast carries the current's field into the gain the family alone fits (the
// member was refused and the scale went missing; scripts/withheld_sim: −0.10 on z beside a log's
// whole current field read −0.068 alone, −0.098 beside it), so the family is fitted beside the field
// (verdict.cc BesideDrive) and its z gain and interval hold the planted one.
TEST(GapScaleFamily, GivenAVerticalAxisScaleBesideAnUnmodelledCurrentField_WhenDiagnosed_ThenTheGainIsReadBesideTheField) {
  gaptest::Flown f = gaptest::FlyInjected({{"current_hard_iron", 0.3}}, 2114, "scale_family", "selftest_flight");
  constexpr double kGain = -0.10;
  ScaleMag2Z(kGain, &f.log);
  const GapReport rep = gaptest::DiagnoseChannel(f.log, f.trial.configured, "mag2");
  const ChannelResult* mag2 = gaptest::FindChannel(rep, "mag2");
  ASSERT_NE(mag2, nullptr);
  EXPECT_TRUE(InEffects(*mag2, "current_hard_iron")) << Summary(rep);
  const CandidateResult* s = gaptest::FindCandidate(*mag2, "scale_error");
  ASSERT_NE(s, nullptr) << Summary(rep);
  ASSERT_TRUE(s->params.count("scale_z_minus_1")) << Summary(rep);
  EXPECT_NEAR(s->params.at("scale_z_minus_1"), kGain, 0.2 * std::fabs(kGain)) << Summary(rep);
  EXPECT_LE(s->magnitude_ci95[0], std::fabs(kGain)) << Summary(rep);
  EXPECT_GE(s->magnitude_ci95[1], std::fabs(kGain)) << Summary(rep);
  EXPECT_TRUE(InEffects(*mag2, "scale_error")) << Summary(rep);
}

// A vertical axis reading 10 % small on a log at a real autopilot's rates beside a current field the
// vehicle file does not model (its latency unmodelled too), flown with `seed`: scale_error in effects,
// sized in the joint fit, its interval widened by a tenth of its width on each side holding the gain.
void ExpectVerticalScaleBesideFieldOnARealLog(uint64_t seed) {
  gaptest::FlownReal r = gaptest::FlyAsRealLog({{"current_hard_iron", 0.3}}, seed, "scale_family");
  constexpr double kGain = -0.10;
  ScaleMag2Z(kGain, &r.log);
  const GapReport rep = gaptest::DiagnoseChannel(r.log, r.flown.trial.configured, "mag2");
  const ChannelResult* mag2 = gaptest::FindChannel(rep, "mag2");
  ASSERT_NE(mag2, nullptr);
  bool found = false;
  for (const EffectShare& e : mag2->effects) {
    if (e.effect != "scale_error") continue;
    found = true;
    const double w = e.ci95.hi - e.ci95.lo;
    EXPECT_LE(e.ci95.lo - 0.1 * w, std::fabs(kGain)) << Summary(rep);
    EXPECT_GE(e.ci95.hi + 0.1 * w, std::fabs(kGain)) << Summary(rep);
  }
  EXPECT_TRUE(found) << "seed " << seed << "\n" << Summary(rep);
}

// Given that on logs at a real autopilot's rates, when diagnosed, then the scale is an effect with its
// size (on each of these flights the vertical member was refused for the gain it moved to alone, and
// no scale_error was named: scripts/withheld_sim's −0.10 z scale beside a 91 ms latency, seed 2028).
TEST(GapScaleFamily, GivenAVerticalAxisScaleBesideAnUnmodelledFieldOnARealLog_WhenDiagnosed_ThenItIsAnEffectWithItsSize) {
  for (uint64_t seed : {2115, 2116, 2117}) ExpectVerticalScaleBesideFieldOnARealLog(seed);
}

// One horizontal axis reading 13 % large beside a 0.11 µT/A current field on a log at a real
// autopilot's rates, flown with `seed`: the scale (taken beside the current's columns, BesideDrive)
// is the first effect, and the current field that joins it is current_hard_iron with its interval,
// widened by a tenth of its width on each side, holding 0.11.
void ExpectCurrentFieldBesideAFirstScale(uint64_t seed) {
  constexpr double kField = 0.11;
  gaptest::FlownReal r =
      gaptest::FlyAsRealLog({{"axis_scale_error", 0.13}, {"current_hard_iron", kField}}, seed, "scale_family");
  const GapReport rep = gaptest::DiagnoseChannel(r.log, r.flown.trial.configured, "mag2");
  const ChannelResult* mag2 = gaptest::FindChannel(rep, "mag2");
  ASSERT_NE(mag2, nullptr);
  EXPECT_TRUE(InEffects(*mag2, "scale_error")) << Summary(rep);
  bool found = false;
  for (const EffectShare& e : mag2->effects) {
    if (e.effect != "current_hard_iron") continue;
    found = true;
    const double w = e.ci95.hi - e.ci95.lo;
    EXPECT_LE(e.ci95.lo - 0.1 * w, kField) << "seed " << seed << "\n" << Summary(rep);
    EXPECT_GE(e.ci95.hi + 0.1 * w, kField) << "seed " << seed << "\n" << Summary(rep);
  }
  EXPECT_TRUE(found) << "seed " << seed << "\n" << Summary(rep);
}

// Given a current field beside an axis scale taken beside the current's columns, when diagnosed, then
// the field joins the scale's model as it is (GrowModel's AsJoined: the scale with its own columns),
// and is sized so: joined to the scale's columns taken beside it, the field took the scale's part
// along the current and throttle (0.197 [0.135, 0.259] µT/A, and throttle_hard_iron 43 µT/throttle
// in place of the current field, on these flights).
TEST(GapScaleFamily, GivenACurrentFieldBesideAFirstAxisScale_WhenDiagnosed_ThenTheFieldIsSizedBesideTheWholeScale) {
  for (uint64_t seed : {2124, 2126, 2128}) ExpectCurrentFieldBesideAFirstScale(seed);
}

// Given a current-driven soft iron on a log at a real autopilot's rates (10 Hz rows, the current
// stale), whose current does not vary enough while the vehicle turns for the soft iron's dependence on
// it to be resolved beyond a constant matrix and the current's own field, when diagnosed, then
// current_soft_iron is not an effect and the report says why: the flight cannot tell it from a static
// calibration error beside a current field.
TEST(GapScaleFamily, GivenASoftIronTheFlightCannotSeparate_WhenDiagnosed_ThenTheReportSaysSo) {
  const gaptest::FlownReal r = gaptest::FlyAsRealLog({{"current_soft_iron", 0.003}}, 2133, "scale_family");
  DiagnoseOptions o;
  o.channels = {"mag2"};
  o.compass_latency_s = r.truth.latency_s;
  auto rep = Diagnose(r.log, r.flown.trial.configured, o);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr);
  EXPECT_FALSE(InEffects(*mag2, "current_soft_iron")) << Summary(*rep);
  EXPECT_TRUE(gaptest::HasFinding(*mag2, "does not vary enough while it turns")) << Summary(*rep);
}

}  // namespace
}  // namespace hexsim::gap
