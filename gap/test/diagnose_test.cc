#include <cmath>
#include <string>
#include <utility>

#include <gtest/gtest.h>

#include "support/gap_fixtures.h"

#include "hexsim/common/rng.h"
#include "hexsim/gap/diagnose.h"
#include "hexsim/gap/selftest.h"

namespace hexsim::gap {
namespace {

// The nuisance line prints the fitted field's horizontal part always and its norm only inside
// field_scale's physical range (0.7..1.3): a public PX4 log's level flight fitted the norm +40 %
// (the vertical field traded with the z offset) beside a horizontal +3.4 %.
TEST(FieldScaleText, GivenANormOutsideItsPhysicalRange_WhenPrinted_ThenOnlyTheHorizontalPartHasANumber) {
  Nuisance n;
  n.present = true;
  n.field_scale_horizontal = 1.034;
  n.field_scale = 1.403;
  const std::string out = FieldScaleText(n);
  EXPECT_NE(out.find("+3.4 %"), std::string::npos) << out;
  EXPECT_EQ(out.find("40"), std::string::npos) << out;
  EXPECT_NE(out.find("not resolved"), std::string::npos) << out;
  n.field_scale = 1.075;
  const std::string in = FieldScaleText(n);
  EXPECT_NE(in.find("norm +7.5 %"), std::string::npos) << in;
}

// A fitted horizontal field against the model's (a public 14S log's external compass: scale −0.059)
// has no size a compass reads: the line says its direction and model mismatch, no "-105.9 %".
TEST(FieldScaleText, GivenAHorizontalFieldAgainstTheModels_WhenPrinted_ThenNoPercentageOnlyItsDirection) {
  Nuisance n;
  n.present = true;
  n.field_scale_horizontal = -0.059;
  n.field_scale = 0.4;
  const std::string out = FieldScaleText(n);
  EXPECT_EQ(out.find("105.9"), std::string::npos) << out;
  EXPECT_EQ(out.find('%'), std::string::npos) << out;
  EXPECT_NE(out.find("points against WMM's: model mismatch"), std::string::npos) << out;
}

// A residual many times the noise floor's power that no test resolves (a public PX4 log's 28-s
// flight: ratio 12.5) is not "at the noise floor": the headline says no gap is resolved, and why.
TEST(Headline, GivenNoGapDetectedWithAResidualManyTimesTheFloor_WhenPrinted_ThenItDoesNotSayAtTheNoiseFloor) {
  ChannelResult c;
  c.channel = "mag";
  c.gap_detected = false;
  c.noise_floor_ratio = 12.52;
  const std::string high = Headline(c);
  EXPECT_EQ(high.find("at the noise floor"), std::string::npos) << high;
  EXPECT_NE(high.find("no gap resolved"), std::string::npos) << high;
  EXPECT_NE(high.find("12.5 times"), std::string::npos) << high;
  c.noise_floor_ratio = 1.04;
  const std::string floor = Headline(c);
  EXPECT_NE(floor.find("no gap: residual at the noise floor (power ratio 1.04)"), std::string::npos) << floor;
}

// A channel with a gap whose verdict is `verdict` and whose one effect is `e` (named the verdict).
ChannelResult HeadlineChannel(const std::string& channel, const std::string& verdict, double noise_floor_ratio,
                              EffectShare e) {
  ChannelResult c;
  c.channel = channel;
  c.gap_detected = true;
  c.noise_floor_ratio = noise_floor_ratio;
  c.verdict = verdict;
  e.effect = verdict;
  c.effects.push_back(std::move(e));
  return c;
}

// An effect material by the heading it turns may predict held-out blocks worse than the baseline (a
// public PX4 log's external compass: current_hard_iron 4.8 mG/A "explains -23 %"): the headline says it
// explains none of the structure and how much worse, never a negative part explained.
TEST(Headline, GivenAHeadlineEffectWithANegativeHeldOutShare_WhenPrinted_ThenItSaysItExplainsNone) {
  EffectShare e;
  e.id = Effect::kCurrentHardIron;
  e.unit = "uT/A";
  e.magnitude = 0.48;
  e.ci95 = {0.17, 0.80};
  e.explained_share = -0.23;
  ChannelResult c = HeadlineChannel("mag2", "current_hard_iron", 3.0, e);
  c.partial = true;
  const std::string line = Headline(c);
  EXPECT_EQ(line.find("-23 %"), std::string::npos) << line;
  EXPECT_NE(line.find("explains none of the held-out structure above the noise floor (held out it predicts 23 % worse"),
            std::string::npos)
      << line;
}

// The per-motor form (c_i·u_i^0.65) is driven by the outputs: on a public ArduCopter ground run with
// an unusable current its verdict read "per_motor_current_hard_iron 25.0 [8.2, 41.8] mG", a field
// with no state it is at. Its size is the motors' fields at full output, and says so.
TEST(Headline, GivenAPerMotorEffect_WhenPrinted_ThenItsSizeSaysItIsTheFieldAtFullOutput) {
  EffectShare e;
  e.id = Effect::kPerMotorCurrentHardIron;
  e.unit = "uT";
  e.autopilot_unit = "mG";
  e.autopilot_factor = 10.0;
  e.magnitude = 2.5;
  e.ci95 = {0.82, 4.18};
  e.explained_share = 0.81;
  ChannelResult c = HeadlineChannel("mag", "per_motor_current_hard_iron", 5.0, e);
  const std::string line = Headline(c);
  EXPECT_NE(line.find("25.0 [8.2, 41.8] mG at full output (all motors)"), std::string::npos) << line;
  // beside it the in-flight model's throttle term, fitted on that ground run: not to be written
  CompassTerms t;
  t.form = "throttle";
  t.term_fitted = true;
  t.term_plausible = true;
  t.term_norm_uT = 1.34;
  t.ground_run_note = "on runs on the ground only";
  c.absolute_terms = t;
  const std::string ground = Headline(c);
  EXPECT_NE(ground.find("absolute throttle term 13.4"), std::string::npos) << ground;
  EXPECT_NE(ground.find("not written: the fit saw no flight"), std::string::npos) << ground;
  EXPECT_EQ(ground.find("COMPASS_MOTCT 1"), std::string::npos) << ground;
}

const ChannelResult* Find(const GapReport& r, const std::string& ch) { return gaptest::FindChannel(r, ch); }

bool NotDiagnosed(const GapReport& r, const std::string& ch) {
  for (const auto& [c, why] : r.not_diagnosed) {
    if (c == ch && !why.empty()) return true;
  }
  return false;
}

using gaptest::Flown;

Flown Fly(const std::vector<Injection>& inj, uint64_t seed) { return gaptest::FlyInjected(inj, seed, "test"); }

TEST(GapDiagnose, GivenACleanSimulatedLogWhenDiagnosedThenTheExternalCompassShowsNoSignificantGap) {
  Flown f = Fly({}, 11);
  auto rep = Diagnose(f.log, f.trial.configured, gaptest::IdealOptions());
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag = Find(*rep, "mag");
  ASSERT_NE(mag, nullptr);
  EXPECT_FALSE(mag->gap_detected) << Summary(*rep);
  EXPECT_EQ(mag->verdict, "none");
}

TEST(GapDiagnose, GivenAWithheldCurrentHardIronWhenDiagnosedThenItIsAttributedAndItsMagnitudeIsInTheInterval) {
  Flown f = Fly({{"current_hard_iron", 0.4}}, 12);
  auto rep = Diagnose(f.log, f.trial.configured, gaptest::IdealOptions());
  ASSERT_TRUE(rep.ok());
  const ChannelResult* mag2 = Find(*rep, "mag2");
  ASSERT_NE(mag2, nullptr);
  EXPECT_TRUE(mag2->gap_detected);
  ASSERT_FALSE(mag2->candidates.empty());
  EXPECT_EQ(mag2->candidates.front().effect, "current_hard_iron") << Summary(*rep);
  const auto& c = mag2->candidates.front();
  // The replay's systematic error (see effects_test.cc): 5 % of the magnitude beside the interval.
  EXPECT_LE(c.magnitude_ci95[0] - 0.05 * c.magnitude, f.trial.true_magnitude[0]);
  EXPECT_GE(c.magnitude_ci95[1] + 0.05 * c.magnitude, f.trial.true_magnitude[0]);
  EXPECT_GE(mag2->explained_share, 0.5);  // of the held-out residual above the baseline
}

TEST(GapDiagnose, GivenALogWithoutAttitudeWhenDiagnosedThenCompassesAreListedAsNotDiagnosedWithTheReason) {
  Flown f = Fly({}, 13);
  logs::FlightLog log;
  for (const auto& name : f.log.columns()) {
    if (name.rfind("q_", 0) != 0) log.AddColumn(name);
  }
  for (size_t i = 0; i < f.log.rows(); ++i) {
    log.AppendRow();
    for (const auto& name : log.columns()) log.Set(name, f.log.Column(name)[i]);
  }
  log.meta = f.log.meta;
  auto rep = Diagnose(log, f.trial.configured, gaptest::IdealOptions());
  ASSERT_TRUE(rep.ok());
  EXPECT_TRUE(rep->channels.empty());
  EXPECT_TRUE(NotDiagnosed(*rep, "mag"));
  EXPECT_TRUE(NotDiagnosed(*rep, "mag2"));
}

// The channels' minimum length skips the inertial channels; a compass is diagnosed whenever the
// in-flight compass model can fit it (its own minimum, flight_fit.h).
TEST(GapDiagnose, GivenALogShorterThanTheChannelMinimumWhenDiagnosedThenInertialChannelsAreSkippedAndCompassesDiagnosed) {
  Flown f = Fly({}, 14);
  DiagnoseOptions o;
  o.min_duration_s = 1e4;
  o.min_samples = 100000;
  auto rep = Diagnose(f.log, f.trial.configured, o);
  ASSERT_TRUE(rep.ok());
  EXPECT_TRUE(NotDiagnosed(*rep, "gyro"));
  EXPECT_FALSE(NotDiagnosed(*rep, "mag"));
  for (const auto& c : rep->channels) {
    EXPECT_EQ(c.channel.rfind("mag", 0), 0u) << c.channel;
    EXPECT_TRUE(c.absolute_terms.has_value()) << c.channel;
  }
}

TEST(GapDiagnose, GivenAnEmptyLogWhenDiagnosedThenItIsBadInput) {
  logs::FlightLog log;
  vehicle::VehicleParams v;
  EXPECT_FALSE(Diagnose(log, v).ok());
}

}  // namespace
}  // namespace hexsim::gap
