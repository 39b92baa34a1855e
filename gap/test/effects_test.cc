// Attribution of each withheld compass effect, clean logs, out-of-library effects, and the
// statistics helpers the gap test relies on.
#include <algorithm>
#include <cmath>
#include <ostream>
#include <string>

#include <gtest/gtest.h>

#include "support/gap_fixtures.h"

#include "../src/stats.h"
#include "hexsim/common/rng.h"
#include "hexsim/gap/diagnose.h"
#include "hexsim/gap/selftest.h"

namespace hexsim::gap {
namespace {

const ChannelResult* Find(const GapReport& r, const std::string& ch) { return gaptest::FindChannel(r, ch); }

const CandidateResult* Candidate(const ChannelResult& c, const std::string& effect) {
  return gaptest::FindCandidate(c, effect);
}

using gaptest::Flown;

Flown Fly(const std::vector<Injection>& inj, uint64_t seed) { return gaptest::FlyInjected(inj, seed, "effects_test"); }

const std::string kInjected = "mag2";  // kSelftestCompass

// ---- statistics helpers ---------------------------------------------------------------------------

TEST(GapStats, GivenTwoNumeratorDegreesOfFreedomWhenTheFTailIsEvaluatedThenItMatchesTheClosedForm) {
  // F(2, d2): P(F > f) = (1 + 2f/d2)^(−d2/2) exactly.
  for (double d2 : {3.0, 11.0, 17.0, 60.0}) {
    for (double f : {0.1, 1.0, 3.5, 12.0}) {
      EXPECT_NEAR(internal::FSf(f, 2, d2), std::pow(1 + 2 * f / d2, -d2 / 2), 1e-9) << f << " " << d2;
    }
  }
}

TEST(GapStats, GivenOneNumeratorDegreeOfFreedomWhenTheFTailIsAtTheSquaredT975ThenItIsFivePercent) {
  // F(1, df) = t(df)²; the t quantile is exact (common/statistics), so the tail is 5 % to 1e-9.
  for (double df : {1.0, 3.0, 10.0, 19.0, 40.0}) {
    const double t = internal::StudentT975(df);
    EXPECT_NEAR(internal::FSf(t * t, 1, df), 0.05, 1e-9) << df;
  }
}

// ---- clean logs -----------------------------------------------------------------------------------

class CleanLog : public ::testing::TestWithParam<uint64_t> {};

TEST_P(CleanLog, GivenACleanSimulatedLogWhenDiagnosedThenNoChannelShowsASignificantGap) {
  Flown f = Fly({}, GetParam());
  auto rep = Diagnose(f.log, f.trial.configured, gaptest::IdealOptions());
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  for (const char* ch : {"mag", "mag2", "mag3", "gyro", "accel", "dynamics"}) {
    const ChannelResult* c = Find(*rep, ch);
    ASSERT_NE(c, nullptr) << ch;
    EXPECT_FALSE(c->gap_detected) << ch << "\n" << Summary(*rep);
    EXPECT_EQ(c->verdict, "none") << ch;
  }
}

INSTANTIATE_TEST_SUITE_P(Seeds, CleanLog, ::testing::Values(201, 202, 203));

TEST(GapDiagnose, GivenACleanLogWhenTheImuIsReplayedThenTheKnownSampleHoldIsWithinOneImuPeriod) {
  Flown f = Fly({}, 204);
  auto rep = Diagnose(f.log, f.trial.configured, gaptest::IdealOptions());
  ASSERT_TRUE(rep.ok());
  const ChannelResult* gyro = Find(*rep, "gyro");
  ASSERT_NE(gyro, nullptr);
  const CandidateResult* lat = Candidate(*gyro, "latency");
  ASSERT_NE(lat, nullptr);
  const double period = 1.0 / f.trial.configured.sensors.gyro.rate_hz;
  const double hold = lat->params.count("known_sample_hold_s") ? lat->params.at("known_sample_hold_s") : -1.0;
  EXPECT_GE(hold, 0.0);
  EXPECT_LE(hold, period);
  EXPECT_LE(lat->magnitude_ci95[0], period);  // total latency consistent with the hold alone
}

// ---- each in-library effect alone ------------------------------------------------------------------

struct EffectCase {
  const char* effect;
  double magnitude;
  uint64_t seed;
};

void PrintTo(const EffectCase& c, std::ostream* os) { *os << c.effect << "_" << c.magnitude; }

class SingleEffect : public ::testing::TestWithParam<EffectCase> {};

TEST_P(SingleEffect, GivenOneWithheldCompassEffectWhenDiagnosedThenItIsAttributedAndItsMagnitudeIsInItsInterval) {
  const EffectCase& c = GetParam();
  Flown f = Fly({{c.effect, c.magnitude}}, c.seed);
  auto rep = Diagnose(f.log, f.trial.configured, gaptest::IdealOptions());
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = Find(*rep, kInjected);
  ASSERT_NE(mag2, nullptr);
  EXPECT_TRUE(mag2->gap_detected) << Summary(*rep);
  EXPECT_EQ(mag2->verdict, c.effect) << Summary(*rep);
  const CandidateResult* k = Candidate(*mag2, c.effect);
  ASSERT_NE(k, nullptr);
  EXPECT_TRUE(k->selected);
  const double truth = std::fabs(f.trial.true_magnitude[0]);
  // Effects are fitted over the nuisance baseline (offset and field), so their
  // magnitude comes from the regressor's variation, not its mean; the replay's systematic error
  // (about 2-4 % of a current-driven field, from interpolating the 100 Hz current at the compass
  // samples) is then no longer negligible against the statistical interval, and the check allows
  // it (5 % of the magnitude).
  const double sys = 0.05 * std::fabs(k->magnitude);
  const double m_lo = (k->magnitude_unit == "1" ? std::fabs(k->magnitude_ci95[0]) : k->magnitude_ci95[0]) - sys;
  const double m_hi = (k->magnitude_unit == "1" ? std::fabs(k->magnitude_ci95[1]) : k->magnitude_ci95[1]) + sys;
  EXPECT_LE(std::min(m_lo, m_hi), truth) << k->magnitude << " " << k->magnitude_unit;
  EXPECT_GE(std::max(m_lo, m_hi), truth) << k->magnitude << " " << k->magnitude_unit;
  // Effects beyond the baseline explain half the held-out residual above it; the nuisance terms
  // (offset, field, scale) are the baseline itself (CONTRACTS.md "Gap diagnosis").
  if (!k->nuisance_term) {
    EXPECT_GE(mag2->explained_share, 0.5);
  }
  // The other compasses are untouched.
  const ChannelResult* mag = Find(*rep, "mag");
  ASSERT_NE(mag, nullptr);
  if (std::string(c.effect) != "local_anomaly") {
    EXPECT_FALSE(mag->gap_detected) << Summary(*rep);
  }
}

INSTANTIATE_TEST_SUITE_P(
    CompassEffects, SingleEffect,
    ::testing::Values(EffectCase{"current_hard_iron", 0.3, 301}, EffectCase{"current_soft_iron", 0.004, 302},
                      EffectCase{"misalignment", 3.0, 303}, EffectCase{"field_scale", 0.04, 304},
                      EffectCase{"local_anomaly", 2.5, 305}, EffectCase{"current_lag", 0.3, 306},
                      EffectCase{"hard_iron_offset", 3.0, 307}, EffectCase{"throttle_hard_iron", 25.0, 308},
                      EffectCase{"temperature_drift", 0.1, 309}),
    [](const ::testing::TestParamInfo<EffectCase>& i) { return std::string(i.param.effect); });

// ---- sensitivity -----------------------------------------------------------------------------------

TEST(GapDiagnose, GivenAOneMilliGaussPerAmpCurrentHardIronWhenDiagnosedThenTheGapIsFlagged) {
  // 0.1 µT/A is the contract's upper bound on the detection threshold (CONTRACTS.md).
  for (uint64_t seed : {401, 402}) {
    Flown f = Fly({{"current_hard_iron", 0.1}}, seed);
    auto rep = Diagnose(f.log, f.trial.configured, gaptest::IdealOptions());
    ASSERT_TRUE(rep.ok());
    const ChannelResult* mag2 = Find(*rep, kInjected);
    ASSERT_NE(mag2, nullptr);
    EXPECT_TRUE(mag2->gap_detected) << Summary(*rep);
  }
}

// ---- temperature drift against a constant offset -----------------------------------------------------

TEST(GapDiagnose, GivenATemperatureDriftAndAHardIronOffsetWhenDiagnosedThenTheDriftDoesNotAbsorbTheOffset) {
  Flown f = Fly({{"temperature_drift", 0.1}, {"hard_iron_offset", 4.0}}, 501);
  auto rep = Diagnose(f.log, f.trial.configured, gaptest::IdealOptions());
  ASSERT_TRUE(rep.ok());
  const ChannelResult* mag2 = Find(*rep, kInjected);
  ASSERT_NE(mag2, nullptr);
  const CandidateResult* td = Candidate(*mag2, "temperature_drift");
  const CandidateResult* hi = Candidate(*mag2, "hard_iron_offset");
  ASSERT_NE(td, nullptr);
  ASSERT_NE(hi, nullptr);
  // The drift is the effect beyond the baseline; the offset is the baseline's (a nuisance term).
  EXPECT_EQ(mag2->verdict, "temperature_drift") << Summary(*rep);
  EXPECT_TRUE(td->selected) << Summary(*rep);
  EXPECT_EQ(td->params.count("b_x_uT"), 0u);
  EXPECT_TRUE(hi->nuisance_term);
  // The offset also holds d·(T_first − 25 °C): the drift's reference is the first flight sample.
  EXPECT_NEAR(hi->magnitude, 4.0, 1.0) << Summary(*rep);
  EXPECT_LE(td->magnitude_ci95[0], 0.1);
  EXPECT_GE(td->magnitude_ci95[1], 0.1);
}

// ---- out of library ----------------------------------------------------------------------------------

struct OutCase {
  const char* effect;
  double magnitude;
  uint64_t seed;
  // Readable and stable in test listings (the default prints the object's bytes, a pointer included).
  friend void PrintTo(const OutCase& c, std::ostream* os) { *os << c.effect << " " << c.magnitude << " seed " << c.seed; }
};

class OutOfLibrary : public ::testing::TestWithParam<OutCase> {};

TEST_P(OutOfLibrary, GivenAnEffectOutsideTheLibraryWhenDiagnosedThenItIsNotAConfidentWrongAnswer) {
  const OutCase& c = GetParam();
  Flown f = Fly({{c.effect, c.magnitude}}, c.seed);
  auto rep = Diagnose(f.log, f.trial.configured, gaptest::IdealOptions());
  ASSERT_TRUE(rep.ok());
  const ChannelResult* mag2 = Find(*rep, kInjected);
  ASSERT_NE(mag2, nullptr);
  EXPECT_TRUE(mag2->gap_detected) << Summary(*rep);
  // CONTRACTS.md: a library candidate that removes half the held-out residual above the noise
  // floor is the verdict even when the cause lies outside the library.
  // The leftover is reported beside the headline, never a veto (CONTRACTS.md "The verdict is a
  // decomposition"): a confident wrong answer is a headline with nothing said about what it leaves.
  const bool not_explained = mag2->verdict == "unexplained" || mag2->verdict == "ambiguous" || mag2->partial;
  bool left_reported = false;
  for (const std::string& s : mag2->findings) left_reported = left_reported || s.find("structure no candidate describes") != std::string::npos;
  EXPECT_TRUE(not_explained || left_reported || mag2->residual_left.share >= 0.3) << Summary(*rep);
}

// current_exponent 1.0: the wiring field grows as I^2. With the powertrain's current limits and spool
// the square's current spans about 4-26 A, over which I^1.5 (the former 0.5) is within a few per cent
// of a line: current_hard_iron then rightly explains > 90 % of it and the case no longer lies outside
// what the library describes on this flight. I^2 over the same range does (75 % linear, the rest a
// part growing with the square of the prediction). At 0.4 (I^1.4) the linear term explains 80-85 %
// and the leftover's shape finding is what says it: a per-motor field, refused alone, joined beside
// the current hard iron and took the curvature (a confident two-effect answer) until powertrain
// forms stopped joining each other on the relaxed rule (GrowModel, BesideAnotherCause).
INSTANTIATE_TEST_SUITE_P(Effects, OutOfLibrary,
                         ::testing::Values(OutCase{"current_exponent", 1.0, 601}, OutCase{"thermal_ramp", 4.0, 602},
                                           OutCase{"current_exponent", 0.4, 603}, OutCase{"current_exponent", 0.4, 604},
                                           OutCase{"current_exponent", 0.4, 605}),
                         [](const ::testing::TestParamInfo<OutCase>& i) { return std::string(i.param.effect) + "_" + std::to_string(i.param.seed); });

}  // namespace
}  // namespace hexsim::gap
