// The verdict as a decomposition (CONTRACTS.md "The verdict is a decomposition"): effects by
// share, the gap relative to the vehicle file, a static per-axis scale as a calibration error, and
// no boilerplate findings.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "../src/selftest_real.h"
#include "support/gap_fixtures.h"

#include "hexsim/common/rng.h"
#include "hexsim/gap/diagnose.h"
#include "hexsim/gap/json.h"
#include "hexsim/gap/selftest.h"

namespace hexsim::gap {
namespace {

using gaptest::InEffects;

// The channels on several threads give the same report as in turn: each channel reads only the
// shared replay and draws from its own random stream.
TEST(GapDecomposition, GivenTwoThreads_WhenDiagnosed_ThenTheReportIsTheSameAsInTurn) {
  gaptest::Flown f = gaptest::FlyInjected({{"current_hard_iron", 1.0}}, 2102, "decomposition");
  DiagnoseOptions one = gaptest::IdealOptions();
  DiagnoseOptions two = one;
  two.threads = 2;
  auto a = Diagnose(f.log, f.trial.configured, one);
  auto b = Diagnose(f.log, f.trial.configured, two);
  ASSERT_TRUE(a.ok()) << a.status().message();
  ASSERT_TRUE(b.ok()) << b.status().message();
  EXPECT_GE(a->channels.size(), 4U);
  EXPECT_EQ(ToJson(*a).dump(), ToJson(*b).dump());
  EXPECT_EQ(Summary(*a), Summary(*b));
}

// Given a clean simulated log, when diagnosed with the default options, then no compass prints an
// implausible fit: an unselected candidate's grid-edge fit (current_lag at 2.2 s) is not a finding.
TEST(GapDecomposition, GivenACleanSimulatedLog_WhenDiagnosed_ThenNoImplausibleFitIsPrinted) {
  gaptest::Flown f = gaptest::FlyInjected({}, 2101, "decomposition");
  auto rep = Diagnose(f.log, f.trial.configured);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  for (const ChannelResult& c : rep->channels) {
    if (c.unit != "uT") continue;
    for (const std::string& s : c.findings) EXPECT_EQ(s.find("implausible"), std::string::npos) << c.channel << ": " << s;
    EXPECT_TRUE(c.effects.empty()) << Summary(*rep);
  }
}

// Given a log whose compasses are later than the vehicle file models, when diagnosed, then the
// latency is an effect named with its size (the gap is relative to the simulator); given the vehicle
// models that latency, it is not.
TEST(GapDecomposition, GivenACompassLaterThanTheVehicleModels_WhenDiagnosed_ThenLatencyIsAnEffectWithItsSize) {
  const gaptest::FlownReal r = gaptest::FlyAsRealLog({}, 2102, "decomposition");
  const internal::RealLogTruth& truth = r.truth;
  const logs::FlightLog* log = &r.log;
  const gaptest::Flown& f = r.flown;
  DiagnoseOptions unmodelled;
  unmodelled.channels = {"mag"};
  auto rep = Diagnose(*log, f.trial.configured, unmodelled);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag = gaptest::FindChannel(*rep, "mag");
  ASSERT_NE(mag, nullptr) << Summary(*rep);
  EXPECT_EQ(mag->verdict, "latency") << Summary(*rep);
  ASSERT_TRUE(InEffects(*mag, "latency")) << Summary(*rep);
  const EffectShare& lat = mag->effects.front();
  EXPECT_LE(lat.ci95.lo, truth.latency_s + 0.01) << Summary(*rep);
  EXPECT_GE(lat.ci95.hi, truth.latency_s - 0.01) << Summary(*rep);
  EXPECT_EQ(lat.autopilot_unit, "ms");

  DiagnoseOptions modelled = unmodelled;
  modelled.compass_latency_s = truth.latency_s;
  auto rep2 = Diagnose(*log, f.trial.configured, modelled);
  ASSERT_TRUE(rep2.ok());
  const ChannelResult* mag_m = gaptest::FindChannel(*rep2, "mag");
  ASSERT_NE(mag_m, nullptr);
  EXPECT_FALSE(InEffects(*mag_m, "latency")) << Summary(*rep2);
}

// Given a compass later than the vehicle models beside a 7-degree misalignment that dominates its
// structure, when diagnosed, then both are effects: the latency is material as every compass effect
// is, by the noise floor's power its alignment removes (LatencyTerm), not only by its share of a
// structure the misalignment holds.
TEST(GapDecomposition, GivenALatencyBesideADominantMisalignment_WhenDiagnosed_ThenBothAreEffects) {
  const gaptest::FlownReal r = gaptest::FlyAsRealLog({{"misalignment", 7.0}}, 2107, "decomposition");
  const internal::RealLogTruth& truth = r.truth;
  DiagnoseOptions o;
  o.channels = {"mag2"};
  auto rep = Diagnose(r.log, r.flown.trial.configured, o);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr) << Summary(*rep);
  EXPECT_EQ(mag2->verdict, "misalignment") << Summary(*rep);
  ASSERT_TRUE(InEffects(*mag2, "latency")) << Summary(*rep);
  for (const EffectShare& e : mag2->effects) {
    if (e.effect != "latency") continue;
    EXPECT_LE(e.ci95.lo, truth.latency_s + 0.01) << Summary(*rep);
    EXPECT_GE(e.ci95.hi, truth.latency_s - 0.01) << Summary(*rep);
  }
}

// Given one compass axis reading 6 % large, when diagnosed, then it is a calibration error
// (scale_error, the gains' spread in its interval), not a current effect.
TEST(GapDecomposition, GivenOneAxisReadingLarge_WhenDiagnosed_ThenItIsAScaleErrorNotACurrentEffect) {
  gaptest::Flown f = gaptest::FlyInjected({{"axis_scale_error", 0.06}}, 2103, "decomposition");
  auto rep = Diagnose(f.log, f.trial.configured, gaptest::IdealOptions());
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr);
  EXPECT_EQ(mag2->verdict, "scale_error") << Summary(*rep);
  EXPECT_FALSE(InEffects(*mag2, "current_soft_iron")) << Summary(*rep);
  ASSERT_FALSE(mag2->effects.empty()) << Summary(*rep);
  const EffectShare& e = mag2->effects.front();
  // The replay's systematic error (effects_test.cc): 5 % of the magnitude beside the interval.
  EXPECT_LE(e.ci95.lo - 0.05 * e.magnitude, 0.06) << Summary(*rep);
  EXPECT_GE(e.ci95.hi + 0.05 * e.magnitude, 0.06) << Summary(*rep);
}

// Given two withheld effects at once, when diagnosed, then both are listed in effects, largest first.
TEST(GapDecomposition, GivenTwoWithheldEffects_WhenDiagnosed_ThenBothAreInEffectsByShare) {
  gaptest::Flown f = gaptest::FlyInjected({{"current_hard_iron", 0.4}, {"misalignment", 4.0}}, 2104, "decomposition");
  auto rep = Diagnose(f.log, f.trial.configured, gaptest::IdealOptions());
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr);
  EXPECT_TRUE(InEffects(*mag2, "current_hard_iron")) << Summary(*rep);
  EXPECT_TRUE(InEffects(*mag2, "misalignment")) << Summary(*rep);
  for (size_t i = 1; i < mag2->effects.size(); ++i) {
    EXPECT_GE(mag2->effects[i - 1].explained_share, mag2->effects[i].explained_share);
  }
  EXPECT_EQ(mag2->verdict, mag2->effects.front().effect);
}

// Given a current field and a residual offset beyond its normal range at once, when diagnosed, then
// the offset the baseline absorbed is an effect beside the current one (after it: its share is not
// over the baseline that absorbed it), and the current effect stays the headline.
TEST(GapDecomposition, GivenACurrentFieldAndAnOffsetBeyondItsNormalRange_WhenDiagnosed_ThenBothAreInEffects) {
  gaptest::Flown f = gaptest::FlyInjected({{"current_hard_iron", 0.5}, {"hard_iron_offset", 15.0}}, 2105, "decomposition");
  auto rep = Diagnose(f.log, f.trial.configured);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr);
  EXPECT_EQ(mag2->verdict, "current_hard_iron") << Summary(*rep);
  ASSERT_TRUE(InEffects(*mag2, "hard_iron_offset")) << Summary(*rep);
  EXPECT_EQ(mag2->effects.back().effect, "hard_iron_offset");
  EXPECT_EQ(mag2->effects.back().source, "nuisance");
  EXPECT_GT(mag2->effects.back().ci95.lo, 5.0);  // beyond the offset's normal range (plausibility table)
  const CandidateResult* off = gaptest::FindCandidate(*mag2, "hard_iron_offset");
  ASSERT_NE(off, nullptr);
  EXPECT_TRUE(off->selected);
  // The offset removes nothing over the baseline that absorbed it: the headline gives it no share.
  const std::string h = Headline(*mag2);
  EXPECT_NE(h.find("hard_iron_offset"), std::string::npos) << h;
  EXPECT_NE(h.find("absorbed by the baseline"), std::string::npos) << h;
  EXPECT_EQ(h.find("(0 %)"), std::string::npos) << h;
}

// Given a current field alone (zero with the motors off, k·I), when diagnosed with the normal
// ranges, then the flight's mean field k·Ī the current-free baseline's offset holds is not a
// residual offset to recalibrate: at zero current, with the current field fitted, the offset is
// normal, and the finding says so.
TEST(GapDecomposition, GivenACurrentFieldAlone_WhenDiagnosed_ThenItsMeanFieldIsNoOffsetToRecalibrate) {
  gaptest::Flown f = gaptest::FlyInjected({{"current_hard_iron", 0.5}}, 2109, "decomposition");
  auto rep = Diagnose(f.log, f.trial.configured);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr);
  EXPECT_EQ(mag2->verdict, "current_hard_iron") << Summary(*rep);
  EXPECT_FALSE(InEffects(*mag2, "hard_iron_offset")) << Summary(*rep);
  bool zero_current = false;
  for (const std::string& s : mag2->findings) {
    EXPECT_EQ(s.find("recalibrate the compass"), std::string::npos) << s;
    zero_current = zero_current || s.find("at zero current") != std::string::npos;
  }
  EXPECT_TRUE(zero_current) << Summary(*rep);
}

// Adds to mag2 white noise (noise_uT per axis) and a current field along its x axis whose variation
// has the RMS field_uT; returns its size, µT/A. centered: the field k·(I − Ī) (its variation only);
// else k·I, zero with the motors off, as a real wiring field.
double AddToMag2(double noise_uT, double field_uT, uint64_t seed, logs::FlightLog* log, bool centered = true) {
  const std::vector<double> I = log->Column("current_A");
  double mean = 0, var = 0;
  size_t n = 0;
  for (double v : I) {
    if (!std::isfinite(v)) continue;
    mean += v;
    ++n;
  }
  if (n < 100) return 0.0;
  mean /= static_cast<double>(n);
  for (double v : I) {
    if (std::isfinite(v)) var += (v - mean) * (v - mean) / static_cast<double>(n);
  }
  const double k = field_uT / std::sqrt(var);
  RngStream rng(seed, "decomposition/noise");
  const size_t cx = static_cast<size_t>(log->ColumnIndex("mag2_x_uT"));
  for (size_t i = 0; i < log->rows(); ++i) {
    for (size_t a = 0; a < 3; ++a) {
      double& m = log->MutableColumn(cx + a)[i];
      if (!std::isfinite(m) || !std::isfinite(I[i])) continue;
      m += rng.Normal(0.0, noise_uT);
      if (a == 0) m += k * (I[i] - (centered ? mean : 0.0));
    }
  }
  return k;
}

// Given a noisy compass (3 µT per axis, ten times the simulated one) whose only structure is a
// current field of 1.2 µT RMS (5 % of the noise power, below the 10 % materiality, as a real internal
// compass's), when diagnosed, then the current field is material by the heading it turns (its
// interval around the truth) and said so; with the heading rule off (material_heading_deg 0) it is
// not an effect.
TEST(GapDecomposition, GivenANoisyCompassWithACurrentFieldThatTurnsTheHeading_WhenDiagnosed_ThenItIsMaterial) {
  gaptest::Flown f = gaptest::FlyInjected({}, 2107, "decomposition", "selftest_flight");
  const double k = AddToMag2(3.0, 1.2, 2107, &f.log);
  ASSERT_GT(k, 0.0);
  const logs::FlightLog& log = f.log;
  const vehicle::VehicleParams& v = f.trial.configured;
  DiagnoseOptions o;
  o.channels = {"mag2"};
  auto rep = Diagnose(log, v, o);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr);
  ASSERT_TRUE(InEffects(*mag2, "current_hard_iron")) << Summary(*rep);
  EXPECT_EQ(mag2->verdict, "current_hard_iron") << Summary(*rep);
  const EffectShare& e = mag2->effects.front();
  EXPECT_LE(e.ci95.lo, 1.05 * k) << Summary(*rep);
  EXPECT_GE(e.ci95.hi, 0.95 * k) << Summary(*rep);
  EXPECT_TRUE(gaptest::HasFinding(*mag2, "by the heading it turns")) << Summary(*rep);

  o.material_heading_deg = 0.0;
  auto off = Diagnose(log, v, o);
  ASSERT_TRUE(off.ok());
  const ChannelResult* mag2_off = gaptest::FindChannel(*off, "mag2");
  ASSERT_NE(mag2_off, nullptr);
  EXPECT_FALSE(InEffects(*mag2_off, "current_hard_iron")) << Summary(*off);
}

// Given a noisy compass whose current field varies little about a large flight mean (k·I, zero with
// the motors off, where the compass was calibrated), when diagnosed, then the field is material by
// the heading its whole field turns from motors off, not only by its variation's; and a current
// field too weak to be material is named in a finding (resolved, not material), not left unsaid.
TEST(GapDecomposition, GivenACurrentFieldWithALargeFlightMean_WhenDiagnosed_ThenItsWholeFieldTurnsTheHeading) {
  gaptest::Flown f = gaptest::FlyInjected({}, 2108, "decomposition", "selftest_flight");
  logs::FlightLog weak = f.log;
  const double k = AddToMag2(3.0, 0.25, 2108, &f.log, /*centered=*/false);
  ASSERT_GT(k, 0.0);
  DiagnoseOptions o;
  o.channels = {"mag2"};
  auto rep = Diagnose(f.log, f.trial.configured, o);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr);
  ASSERT_TRUE(InEffects(*mag2, "current_hard_iron")) << Summary(*rep);
  EXPECT_TRUE(gaptest::HasFinding(*mag2, "from motors off")) << Summary(*rep);

  AddToMag2(3.0, 0.25, 2108, &weak, /*centered=*/true);
  o.material_heading_deg = 3.0;  // a stricter heading rule: the same field's variation is not material
  auto rep2 = Diagnose(weak, f.trial.configured, o);
  ASSERT_TRUE(rep2.ok());
  const ChannelResult* w = gaptest::FindChannel(*rep2, "mag2");
  ASSERT_NE(w, nullptr);
  EXPECT_FALSE(InEffects(*w, "current_hard_iron")) << Summary(*rep2);
  EXPECT_TRUE(gaptest::HasFinding(*w, "is resolved (p")) << Summary(*rep2);
}

}  // namespace
}  // namespace hexsim::gap
