// The selftest's real profile: a simulated trial degraded to real logging rates and timing.
#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "../src/selftest_real.h"
#include "hexsim/common/rng.h"
#include "support/gap_fixtures.h"

namespace hexsim::gap {
namespace {

TEST(GapRealProfile, GivenADegradedTrial_WhenDiagnosed_ThenRowsAre10HzAndTimingRecoversTheInjectedLatencyAndStaleness) {
  gaptest::Flown f = gaptest::FlyInjected({{"current_hard_iron", 0.5}}, 711, "real_profile_test");
  RngStream rng(711, "real_profile_test");
  internal::RealLogTruth truth;
  auto log = internal::DegradeToRealLog(f.log, f.trial.configured, &rng, &truth);
  ASSERT_TRUE(log.ok()) << log.status().message();
  const auto& t = log->Column("t_s");
  ASSERT_GT(log->rows(), 100u);
  EXPECT_NEAR((t.back() - t.front()) / static_cast<double>(log->rows() - 1), 0.1, 0.01);
  // The current updates at 5 Hz: about half of its 10 Hz samples repeat.
  std::set<double> updates(log->Column("batt_t_s").begin(), log->Column("batt_t_s").end());
  EXPECT_LT(updates.size(), log->rows() * 6 / 10);
  // Each compass sample is logged exactly L after it was measured: its stamp minus L is one of the
  // simulator's own sample stamps, and its value is that sample's (scale and offset applied).
  std::set<double> source(f.log.Column("mag2_t_s").begin(), f.log.Column("mag2_t_s").end());
  const auto& stamp = log->Column("mag2_t_s");
  int exact = 0;
  for (double s : stamp) {
    const auto it = source.lower_bound(s - truth.latency_s - 1e-9);
    exact += it != source.end() && std::fabs(*it - (s - truth.latency_s)) < 1e-9;
  }
  EXPECT_EQ(exact, static_cast<int>(stamp.size()));

  // The trial's configured vehicle models the compass latency it injected (the gap is relative to it).
  DiagnoseOptions opt;
  opt.compass_latency_s = truth.latency_s;
  auto rep = Diagnose(*log, f.trial.configured, opt);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr) << Summary(*rep);
  ASSERT_TRUE(mag2->timing.latency.present && mag2->timing.current_staleness.present) << Summary(*rep);
  EXPECT_NEAR(mag2->timing.latency.value_s, truth.latency_s, 0.03) << Summary(*rep);
  const LagReport& st = mag2->timing.current_staleness;
  // Staleness against throttle: the injected staleness plus the motors' own throttle-to-current
  // response (tens of ms); the interval holds it.
  // The current is updated at 5 Hz: within half its update period (0.1 s) is what a lag scan can
  // resolve. (This trial, drawn the same by every compiler since the draws were sequenced, has
  // 198 ms injected and reads 138 ms [76, 193]: a single 95 % interval may miss; the selftest's
  // coverage counts those misses.)
  EXPECT_LE(st.ci95_s.lo, truth.staleness_s + 0.1) << Summary(*rep);
  EXPECT_NEAR(st.value_s, truth.staleness_s, 0.1) << Summary(*rep);
  // With a stale current updated at 5 Hz, the smooth throttle can carry the current-driven field
  // as well as the logged current: either, or "ambiguous" between them, is the right answer here
  // (they separate only by a manoeuvre, SeparatingManoeuvre); the untouched compasses show no gap.
  EXPECT_TRUE(mag2->verdict == "current_hard_iron" || mag2->verdict == "throttle_hard_iron" ||
              mag2->verdict == "ambiguous")
      << Summary(*rep);
  EXPECT_EQ(gaptest::FindChannel(*rep, "mag")->verdict, "none") << Summary(*rep);
}

// The sensor scale is read from the horizontal field. In a nearly level flight the vertical field's
// column differs from a body-z offset only through the tilts, and the current (which grows with the
// thrust, 1/cos(tilt)) carries every mispredicted current-driven field into it: the whole field's
// norm then reads the scale 5-8 % too large (relative), outside its interval in most trials. The
// real profile's flight: climbs, descents, fast and slow legs. Half the trials read the field low: the
// scale's magnitude is signed, and its interval is never clipped at zero.
TEST(GapRealProfile, GivenAScaleErrorOnALogWithoutPerMotorCurrents_WhenDiagnosed_ThenTheScaleTermsIntervalHoldsTheTruth) {
  int covered = 0, norm_further = 0, named = 0;
  constexpr int kTrials = 6;
  for (int k = 0; k < kTrials; ++k) {
    const uint64_t seed = 1001 + static_cast<uint64_t>(k);
    const double injected = k % 2 == 0 ? 0.1 : -0.1;
    gaptest::Flown f = gaptest::FlyInjected({{"field_scale", injected}}, seed, "real_profile_scale", "selftest_flight");
    RngStream rng(seed, "real_profile_scale/degrade");
    internal::RealLogTruth lt;
    auto log = internal::DegradeToRealLog(f.log, f.trial.configured, &rng, &lt);
    ASSERT_TRUE(log.ok()) << log.status().message();
    DiagnoseOptions opt;
    opt.compass_latency_s = lt.latency_s;  // modelled: only the scale is withheld
    auto rep = Diagnose(*log, f.trial.configured, opt);
    ASSERT_TRUE(rep.ok()) << rep.status().message();
    const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
    ASSERT_NE(mag2, nullptr) << Summary(*rep);
    // The uniform gain is the baseline's nuisance term (the per-axis family holds the axes' differences).
    const CandidateResult* sc = nullptr;
    for (const CandidateResult& k : mag2->candidates) {
      if (k.effect == "field_scale" && k.nuisance_term && sc == nullptr) sc = &k;
    }
    ASSERT_NE(sc, nullptr) << Summary(*rep);
    const double truth = (1 + injected) * (1 + lt.scale) - 1;
    EXPECT_LE(sc->magnitude_ci95[0], sc->magnitude) << Summary(*rep);
    EXPECT_GE(sc->magnitude_ci95[1], sc->magnitude) << Summary(*rep);
    covered += truth >= sc->magnitude_ci95[0] && truth <= sc->magnitude_ci95[1];
    const double norm = mag2->nuisance.field_scale - 1;
    norm_further += std::fabs(norm - truth) > std::fabs(sc->magnitude - truth);
    EXPECT_NEAR(mag2->nuisance.field_scale_horizontal, 1 + sc->magnitude, 1e-12);
    // Named: the verdict, or an effect beside a current field. The sensor's gain scales the wiring
    // field too, which the vehicle file models unscaled: a current-driven gap s·d·I (10 % of quad_x's
    // 4 mG/A at mag2: 0.4 mG/A) that turns the heading about 1.4 deg RMS over a full turn of
    // heading (verdict.h HeadingTurnOf), material by the heading rule in some trials; the scale is
    // then reported beside it.
    bool beside = false;
    for (const EffectShare& e : mag2->effects) beside = beside || e.effect == "field_scale";
    named += mag2->verdict == "field_scale" || beside;
  }
  // 95 % intervals: one miss in six is allowed (measured: 10 of 10 held, the norm further in 10).
  EXPECT_GE(covered, kTrials - 1);
  EXPECT_GE(norm_further, kTrials - 1);
  EXPECT_GE(named, kTrials - 1);
}

// A field read 35 % below WMM is beyond what a compass reads of the Earth field (field_scale's
// physical range 0.7-1.3): "model mismatch", never "recalibrate", and never the verdict.
TEST(GapRealProfile, GivenAFieldReadFarBelowWmm_WhenDiagnosed_ThenTheScaleIsAModelMismatchNotAFinding) {
  gaptest::Flown f = gaptest::FlyInjected({{"field_scale", -0.35}}, 1101, "real_profile_mismatch");
  auto rep = Diagnose(f.log, f.trial.configured);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr) << Summary(*rep);
  bool mismatch = false, recalibrate = false;
  for (const std::string& s : mag2->findings) {
    mismatch = mismatch || (s.find("fitted field") != std::string::npos && s.find("model mismatch") != std::string::npos);
    recalibrate = recalibrate || s.find("recalibrate (scale)") != std::string::npos;
  }
  EXPECT_TRUE(mismatch) << Summary(*rep);
  EXPECT_FALSE(recalibrate) << Summary(*rep);
  EXPECT_NE(mag2->verdict, "field_scale") << Summary(*rep);
}

}  // namespace
}  // namespace hexsim::gap
