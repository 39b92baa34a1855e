// current_lag's free member: a withheld current field that lags the current (first-order, τ) and
// grows as a power p of it is named current_lag with its lag recovered; a field without a lag, or
// one that grows faster than the exponent's physical range, is no current_lag finding.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "../src/selftest_real.h"
#include "hexsim/common/rng.h"
#include "hexsim/gap/diagnose.h"
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
  RngStream rng(seed, "lagged_current/degrade");
  internal::RealLogTruth truth;
  auto real = internal::DegradeToRealLog(log, f.trial.configured, &rng, &truth);
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
