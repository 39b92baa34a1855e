// current_lag: a withheld current field that lags the current (first-order, τ) and grows as a power
// p of it is named current_lag with its lag recovered and under timing; the vehicle file's own field
// arriving late is current_lag too (judged by its timing); a field without a lag, one that grows
// faster than the exponent's physical range, or a field leading the modelled current is no
// current_lag finding.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "../src/selftest_real.h"
#include "hexsim/common/rng.h"
#include "hexsim/gap/diagnose.h"
#include "hexsim/gap/json.h"
#include "support/gap_fixtures.h"

namespace hexsim::gap {
namespace {

// Adds d·a·(lp_τ(I)/I_med)^p to mag2 at the simulator's rate (a = 4 µT at the flight's median
// current, d a fixed direction in the sensor frame), degrades the log to real logging (10 Hz rows,
// a stale 5 Hz current, compass latency) and diagnoses mag2 against the configured vehicle, which
// models that latency.
struct Diagnosed {
  GapReport report;
  const ChannelResult* mag2 = nullptr;
};

// The flown log degraded to real logging (10 Hz rows, a stale 5 Hz current, compass latency) and
// mag2 diagnosed against the configured vehicle, which models that latency.
Diagnosed DegradeAndDiagnose(const gaptest::Flown& f, uint64_t seed, const std::string& stream) {
  RngStream rng(seed, stream);
  internal::RealLogTruth truth;
  auto real = internal::DegradeToRealLog(f.log, f.trial.configured, &rng, &truth);
  EXPECT_TRUE(real.ok()) << real.status().message();
  DiagnoseOptions opt;
  opt.channels = {"mag2"};
  opt.compass_latency_s = truth.latency_s;
  auto rep = Diagnose(*real, f.trial.configured, opt);
  EXPECT_TRUE(rep.ok()) << rep.status().message();
  Diagnosed out;
  out.report = std::move(*rep);
  out.mag2 = gaptest::FindChannel(out.report, "mag2");
  return out;
}

Diagnosed DiagnoseLaggedPowerField(uint64_t seed, double tau_s, double p) {
  gaptest::Flown f = gaptest::FlyInjected({}, seed, "lagged_current", "selftest_flight");
  logs::FlightLog& log = f.log;
  const std::vector<double>& t = log.Column("t_s");
  const std::vector<double>& I = log.Column("current_A");
  std::vector<double> sorted;
  for (double x : I) {
    if (std::isfinite(x)) sorted.push_back(x);
  }
  std::sort(sorted.begin(), sorted.end());
  const double I_med = sorted[sorted.size() / 2];
  const Eigen::Vector3d d = Eigen::Vector3d(0.6, -0.48, 0.64).normalized();
  const size_t cx = static_cast<size_t>(log.ColumnIndex("mag2_x_uT"));
  double lagged = std::isfinite(I.front()) ? I.front() : 0.0;
  for (size_t i = 0; i < log.rows(); ++i) {
    const double x = std::isfinite(I[i]) ? std::max(0.0, I[i]) : 0.0;
    const double dt = i > 0 ? t[i] - t[i - 1] : 0.0;
    lagged = tau_s > 0 ? lagged + (x - lagged) * (1.0 - std::exp(-dt / tau_s)) : x;
    for (size_t k = 0; k < 3; ++k) {
      double& m = log.MutableColumn(cx + k)[i];
      if (std::isfinite(m)) m += d[static_cast<Eigen::Index>(k)] * 4.0 * std::pow(lagged / I_med, p);
    }
  }
  return DegradeAndDiagnose(f, seed, "lagged_current/degrade");
}

const CandidateResult* LagCandidate(const ChannelResult& c) { return gaptest::FindCandidate(c, "current_lag"); }

// Given a current field that lags the current by 0.5 s and grows as I^1.5, when diagnosed, then it
// is current_lag, its lag's interval holds 0.5 s and its exponent's holds 1.5.
TEST(GapLaggedCurrent, GivenALaggedPowerLawCurrentField_WhenDiagnosed_ThenItIsCurrentLagWithItsLagAndExponent) {
  const Diagnosed d = DiagnoseLaggedPowerField(3101, 0.5, 1.5);
  ASSERT_NE(d.mag2, nullptr) << Summary(d.report);
  EXPECT_EQ(d.mag2->verdict, "current_lag") << Summary(d.report);
  const CandidateResult* lag = LagCandidate(*d.mag2);
  ASSERT_NE(lag, nullptr) << Summary(d.report);
  EXPECT_TRUE(lag->selected && lag->plausible) << Summary(d.report);
  EXPECT_LE(lag->magnitude_ci95[0], 0.5) << Summary(d.report);
  EXPECT_GE(lag->magnitude_ci95[1], 0.5) << Summary(d.report);
  ASSERT_TRUE(lag->ci95.count("exponent")) << Summary(d.report);
  EXPECT_LE(lag->ci95.at("exponent").lo, 1.5) << Summary(d.report);
  EXPECT_GE(lag->ci95.at("exponent").hi, 1.5) << Summary(d.report);
  // Resolved: its interval excludes zero.
  EXPECT_GT(lag->magnitude_ci95[0], 0.0) << Summary(d.report);
  // One current effect: its lag under the channel's timing, measured against the logged current.
  const LagReport& tl = d.mag2->timing.current_field_lag;
  EXPECT_TRUE(tl.present && tl.resolved && tl.plausible) << Summary(d.report);
  EXPECT_EQ(tl.against, "current_A");
  EXPECT_DOUBLE_EQ(tl.value_s, lag->magnitude);
  EXPECT_LE(tl.ci95_s.lo, 0.5) << Summary(d.report);
  EXPECT_GE(tl.ci95_s.hi, 0.5) << Summary(d.report);
  // gap.json carries it under the channel's timing, stdout on its timing line.
  const nlohmann::json j = ToJson(d.report);
  bool in_json = false;
  for (const auto& c : j.at("channels")) {
    if (c.at("channel") == "mag2") in_json = c.at("timing").at("current_field_lag_s").at("value") == tl.value_s;
  }
  EXPECT_TRUE(in_json);
  EXPECT_NE(Summary(d.report).find("current field lag behind the current"), std::string::npos) << Summary(d.report);
}

// The ideal profile's square (steady legs: the current changes little, as in a real hover) degraded
// to real logging (a stale 5 Hz current, compass latency), on which, as
// scripts/corpus/inject.py plants a withheld effect, the logged compass gets a field the vehicle file
// does not model: the wires' own a·I in one direction plus d·I0·(lp_τ(I)/I0)^1.6 in another, both of
// the LOGGED current (I0 its median), then diagnosed against the configured vehicle.
Diagnosed DiagnosePlantedLaggedField(uint64_t seed, double tau_s) {
  gaptest::Flown f = gaptest::FlyInjected({}, seed, "planted_lag", "");
  RngStream rng(seed, "planted_lag/degrade");
  internal::RealLogTruth truth;
  auto real = internal::DegradeToRealLog(f.log, f.trial.configured, &rng, &truth);
  EXPECT_TRUE(real.ok()) << real.status().message();
  logs::FlightLog& log = *real;
  const std::vector<double>& t = log.Column("t_s");
  const std::vector<double>& I = log.Column("current_A");
  std::vector<double> sorted;
  for (double x : I) {
    if (std::isfinite(x) && x > 0) sorted.push_back(x);
  }
  std::sort(sorted.begin(), sorted.end());
  const double I0 = sorted[sorted.size() / 2];
  const Eigen::Vector3d a = 0.5 * Eigen::Vector3d(0.6, -0.48, 0.64).normalized();  // µT/A
  const Eigen::Vector3d d = 0.5 * Eigen::Vector3d(-0.3, 0.8, 0.52).normalized();  // µT/A at I0
  const size_t cx = static_cast<size_t>(log.ColumnIndex("mag2_x_uT"));
  double lagged = std::isfinite(I.front()) ? std::max(0.0, I.front()) : 0.0;
  for (size_t i = 0; i < log.rows(); ++i) {
    const double x = std::isfinite(I[i]) ? std::max(0.0, I[i]) : 0.0;
    const double dt = i > 0 ? t[i] - t[i - 1] : 0.0;
    lagged += (x - lagged) * (1.0 - std::exp(-dt / tau_s));
    for (size_t k = 0; k < 3; ++k) {
      double& m = log.MutableColumn(cx + k)[i];
      const Eigen::Index j = static_cast<Eigen::Index>(k);
      if (std::isfinite(m)) m += a[j] * x + d[j] * I0 * std::pow(lagged / I0, 1.6);
    }
  }
  DiagnoseOptions opt;
  opt.channels = {"mag2"};
  opt.compass_latency_s = truth.latency_s;
  auto rep = Diagnose(log, f.trial.configured, opt);
  EXPECT_TRUE(rep.ok()) << rep.status().message();
  Diagnosed out;
  out.report = std::move(*rep);
  out.mag2 = gaptest::FindChannel(out.report, "mag2");
  return out;
}

// Given a field lagging the logged current by 0.5 s and growing as its 1.6th power beside an
// unmodelled unlagged wire field in another direction, when diagnosed, then a current-driven effect
// is named and the channel's timing holds the lag behind the logged current in its interval,
// resolved from zero, whichever current family is named (current_lag's one free direction cannot
// describe both fields: on seed 3131 the effect named is current_hard_iron, and the lag is the timing
// scan's, ScanCurrentFieldLag).
TEST(GapLaggedCurrent, GivenALaggedPowerLawFieldBesideAnUnlaggedOne_WhenDiagnosed_ThenTheTimingHoldsTheLagBehindTheLoggedCurrent) {
  constexpr double kTau = 0.5;
  int covered = 0;
  for (uint64_t seed = 3131; seed < 3133; ++seed) {
    const Diagnosed d = DiagnosePlantedLaggedField(seed, kTau);
    ASSERT_NE(d.mag2, nullptr) << Summary(d.report);
    bool current_driven = false;
    for (const EffectShare& e : d.mag2->effects) {
      current_driven = current_driven || e.id == Effect::kCurrentHardIron || e.id == Effect::kCurrentLag ||
                       e.id == Effect::kCurrentSoftIron || e.id == Effect::kPerMotorCurrentHardIron ||
                       e.id == Effect::kThrottleHardIron;
    }
    EXPECT_TRUE(current_driven) << Summary(d.report);
    const LagReport& tl = d.mag2->timing.current_field_lag;
    ASSERT_TRUE(tl.present) << Summary(d.report);
    EXPECT_EQ(tl.against, "current_A");
    covered += tl.resolved && tl.ci95_s.lo <= kTau && kTau <= tl.ci95_s.hi;
  }
  EXPECT_EQ(covered, 2);
}

// The vehicle file's own wiring field arriving through a lag τ it does not model (the selftest's
// one-effect current_lag; τ = 0: a clean log), on real-profile logs.
Diagnosed DiagnoseLateWiring(uint64_t seed, double tau_s) {
  std::vector<Injection> inj;
  if (tau_s > 0) inj.push_back({"current_lag", tau_s});
  return DegradeAndDiagnose(gaptest::FlyInjected(inj, seed, "late_wiring", "selftest_flight"), seed, "late_wiring/degrade");
}

// Given the modelled wiring field arriving 0.15 s late, when diagnosed, then it is current_lag with
// its lag under timing: material by its timing against the vehicle file (as the compass latency
// is), since what a lag changes, τ·dB/dt, removes only 1-3 % of the noise floor's power (by that
// rule alone no such trial is named). Measured: named 2 of 3, each by its timing, the lag's interval
// (after the plug-ins) holding 0.15 s in both.
TEST(GapLaggedCurrent, GivenTheModelledWiringFieldArrivingLate_WhenDiagnosed_ThenItIsCurrentLagWithItsLagUnderTiming) {
  constexpr double kTau = 0.15;
  int named = 0, by_timing = 0, covered = 0;
  for (uint64_t seed = 3111; seed < 3114; ++seed) {
    const Diagnosed d = DiagnoseLateWiring(seed, kTau);
    ASSERT_NE(d.mag2, nullptr) << Summary(d.report);
    if (d.mag2->verdict != "current_lag") continue;
    ++named;
    const LagReport& tl = d.mag2->timing.current_field_lag;
    EXPECT_TRUE(tl.present && tl.plausible) << Summary(d.report);
    EXPECT_EQ(tl.against, "current_A");
    // Resolved as selected; the current's staleness, a plug-in, trades with the lag one for one and
    // may widen the reported interval to 0 (then said: not resolved).
    EXPECT_EQ(tl.resolved, tl.ci95_s.lo > 0) << Summary(d.report);
    covered += tl.ci95_s.lo <= kTau && kTau <= tl.ci95_s.hi;
    for (const std::string& s : d.mag2->findings) by_timing += s.rfind("current_lag is material by its timing", 0) == 0;
  }
  EXPECT_GE(named, 2);
  EXPECT_GE(by_timing, 2);
  EXPECT_GE(covered, 2);
}

// Given a clean real-profile log, when diagnosed, then current_lag is no effect: its configured-
// wiring member fits the logged current's timing there (the field LEADS the modelled current:
// amplitude a < 0, significant), which is no lag (a outside 0 < a <= 1).
TEST(GapLaggedCurrent, GivenACleanRealProfileLog_WhenDiagnosed_ThenAFieldLeadingTheCurrentIsNoLag) {
  int leading = 0;
  for (uint64_t seed = 3121; seed < 3123; ++seed) {
    const Diagnosed d = DiagnoseLateWiring(seed, 0.0);
    ASSERT_NE(d.mag2, nullptr) << Summary(d.report);
    EXPECT_EQ(d.mag2->verdict, "none") << Summary(d.report);
    // The current field's lag is measured under timing as the latency is, and is not resolved here.
    EXPECT_FALSE(d.mag2->timing.current_field_lag.present && d.mag2->timing.current_field_lag.resolved)
        << Summary(d.report);
    const CandidateResult* lag = LagCandidate(*d.mag2);
    ASSERT_NE(lag, nullptr) << Summary(d.report);
    EXPECT_FALSE(lag->selected) << Summary(d.report);
    leading += lag->params.count("amplitude") && lag->params.at("amplitude") < 0 && lag->p_value <= 0.01;
  }
  // The case the amplitude's range is for (measured: both seeds).
  EXPECT_GE(leading, 1);
}

// Given a current field ∝ I^1.5 without a lag, when diagnosed, then no lag is reported: current_lag's
// lag is not resolved (its unlagged members are as good), so it is not an effect.
TEST(GapLaggedCurrent, GivenAPowerLawCurrentFieldWithoutALag_WhenDiagnosed_ThenCurrentLagIsNoEffect) {
  const Diagnosed d = DiagnoseLaggedPowerField(3102, 0.0, 1.5);
  ASSERT_NE(d.mag2, nullptr) << Summary(d.report);
  EXPECT_TRUE(d.mag2->gap_detected) << Summary(d.report);
  for (const EffectShare& e : d.mag2->effects) EXPECT_NE(e.effect, "current_lag") << Summary(d.report);
}

// Given a lagged current field that grows as I^3, beyond the exponent's physical range 1..2, when
// diagnosed, then current_lag is not the verdict: its fit is refused as a model mismatch, never a
// finding.
TEST(GapLaggedCurrent, GivenALaggedFieldGrowingFasterThanItsRange_WhenDiagnosed_ThenItIsAModelMismatchNotCurrentLag) {
  const Diagnosed d = DiagnoseLaggedPowerField(3103, 0.5, 3.0);
  ASSERT_NE(d.mag2, nullptr) << Summary(d.report);
  for (const EffectShare& e : d.mag2->effects) EXPECT_NE(e.effect, "current_lag") << Summary(d.report);
  const CandidateResult* lag = LagCandidate(*d.mag2);
  ASSERT_NE(lag, nullptr) << Summary(d.report);
  EXPECT_FALSE(lag->plausible) << Summary(d.report);
  for (const std::string& s : d.mag2->findings) {
    if (s.rfind("current_lag", 0) == 0) {
      EXPECT_NE(s.find("model mismatch"), std::string::npos) << s;
    }
  }
}

}  // namespace
}  // namespace hexsim::gap
