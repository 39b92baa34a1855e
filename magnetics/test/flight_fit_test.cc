// The attitude-aided flight fit (flight_fit.h) on synthetic flights with a known offset, current
// field and Earth field, and serially correlated noise as real logs have.
#include <cmath>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "hexsim/common/rng.h"
#include "hexsim/common/statistics.h"
#include "hexsim/magnetics/flight_fit.h"

namespace hexsim::magnetics {
namespace {

using Eigen::Vector3d;

struct SynthFlight {
  Vector3d field_N_uT{20.0, 5.0, -50.0};  // a southern-hemisphere field (up is negative D)
  Vector3d offset_uT{8.0, -3.0, 25.0};
  Vector3d d_uT_per_A{-0.05, -0.35, 0.18};  // |d| = 4 mG/A
  double noise_uT = 0.8;                     // AR(1) at 10 Hz with a 2 s correlation time
  double duration_s = 160.0;
};

// 10 Hz samples: a slow yaw sweep with ±15° roll/pitch manoeuvres and a current that follows
// the manoeuvres (8–20 A).
std::vector<FlightFitSample> Fly(const SynthFlight& f, uint64_t seed, bool with_current = true) {
  RngStream rng(seed, "flight_fit_test");
  std::vector<FlightFitSample> out;
  Vector3d e = Vector3d::Zero();
  const double a = std::exp(-0.1 / 2.0);
  for (double t = 0.0; t < f.duration_s; t += 0.1) {
    const double yaw = 2.0 * M_PI * t / 40.0, roll = 0.26 * std::sin(t / 3.0), pitch = 0.26 * std::cos(t / 5.0);
    const Eigen::Matrix3d R = (Eigen::AngleAxisd(yaw, Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Vector3d::UnitY()) *
                               Eigen::AngleAxisd(roll, Vector3d::UnitX()))
                                  .toRotationMatrix();
    const double I = 14.0 + 6.0 * std::sin(t / 7.0) * std::cos(t / 2.3);
    e = a * e + std::sqrt(1.0 - a * a) * rng.Normal3(f.noise_uT);
    FlightFitSample s;
    s.R_NB = R;
    s.t_s = t;
    s.current_A = with_current ? I : std::nan("");
    s.y_uT = R.transpose() * f.field_N_uT + f.offset_uT + f.d_uT_per_A * I + e;
    out.push_back(s);
  }
  return out;
}

FlightFitOptions Options(const SynthFlight& f) {
  FlightFitOptions o;
  // The WMM prior a little off, as a real site's field is.
  o.prior_field_N_uT = f.field_N_uT + Vector3d(0.6, -0.4, 0.5);
  return o;
}

TEST(FlightFit, GivenAFlightWithKnownOffsetAndCurrentField_WhenFitted_ThenEachIsInsideItsInterval) {
  const SynthFlight f;
  int covered = 0, resolved = 0;
  const int seeds = 20;
  for (int seed = 1; seed <= seeds; ++seed) {
    auto fit = FitFlightCompass(Fly(f, static_cast<uint64_t>(seed)), Options(f));
    ASSERT_TRUE(fit.ok()) << fit.status().message();
    ASSERT_TRUE(fit->term_fitted);
    resolved += fit->term_resolved;
    bool all = true;
    for (int k = 0; k < 3; ++k) {
      all = all && std::fabs(fit->offset_y_uT(k) - f.offset_uT(k)) <= fit->offset_ci_half_uT(k);
      all = all && std::fabs(fit->term_uT(k) - f.d_uT_per_A(k)) <= fit->term_ci_half_uT(k);
    }
    covered += all;
    EXPECT_LT(fit->rms_after_uT, 1.2 * f.noise_uT);
    EXPECT_GT(fit->rms_prior_uT, 10.0 * fit->rms_after_uT);
    EXPECT_GE(fit->blocks, 15);
  }
  EXPECT_EQ(resolved, seeds);
  // Six intervals at 95 % each, jointly: most flights cover all six.
  EXPECT_GE(covered, seeds * 6 / 10);
}

// A PX4 log's compass at 1 Hz (luk8426/flugdrohne's sensor_mag): 50 s of flight hold 50 samples.
// The minimum follows from the model's 9 unknowns (10 equations each, 3 per sample: 30 samples), not
// from a 10 Hz logging rate (it was 60 samples); the interval still covers the truth.
TEST(FlightFit, GivenA1HzCompassOver50s_WhenFitted_ThenItFitsAndTheIntervalCoversTheCurrentField) {
  SynthFlight f;
  f.duration_s = 50.0;
  EXPECT_EQ(MinFlightFitSamples(), 30);
  int covered = 0;
  const int seeds = 20;
  for (int seed = 1; seed <= seeds; ++seed) {
    const std::vector<FlightFitSample> dense = Fly(f, static_cast<uint64_t>(seed));
    std::vector<FlightFitSample> s;
    for (size_t i = 0; i < dense.size(); i += 10) s.push_back(dense[i]);  // 1 Hz
    ASSERT_EQ(s.size(), 50u);
    FlightFitOptions o = Options(f);
    o.block_s = 50.0 / 12.0;  // compass_flight.h: span / (2·min_blocks) on a short log
    auto fit = FitFlightCompass(s, o);
    ASSERT_TRUE(fit.ok()) << fit.status().message();
    ASSERT_TRUE(fit->term_fitted);
    const double truth = f.d_uT_per_A.norm();
    covered += fit->term_norm_ci95[0] <= truth && truth <= fit->term_norm_ci95[1];
  }
  EXPECT_GE(covered, seeds * 8 / 10);
}

TEST(FlightFit, GivenNoCurrentField_WhenFitted_ThenTheCurrentTermIsRarelyResolved) {
  SynthFlight f;
  f.d_uT_per_A.setZero();
  int resolved = 0;
  const int seeds = 20;
  for (int seed = 1; seed <= seeds; ++seed) {
    auto fit = FitFlightCompass(Fly(f, 100 + static_cast<uint64_t>(seed)), Options(f));
    ASSERT_TRUE(fit.ok()) << fit.status().message();
    resolved += fit->term_resolved;
  }
  EXPECT_LE(resolved, 3);  // a 5 % test: 1 expected in 20
}

// Given no current field, when a fit's term is not resolved from zero (its Bonferroni test over three
// axes), then its norm's interval holds zero: "[0.2, 3.0], not resolved from zero" contradicts itself
// (one axis's 95 % interval can exclude zero while the three-axis test does not).
TEST(FlightFit, GivenATermNotResolvedFromZero_WhenItsNormIntervalIsReported_ThenItHoldsZero) {
  SynthFlight f;
  f.d_uT_per_A.setZero();
  int unresolved = 0;
  for (int seed = 1; seed <= 40; ++seed) {
    auto fit = FitFlightCompass(Fly(f, 300 + static_cast<uint64_t>(seed)), Options(f));
    ASSERT_TRUE(fit.ok()) << fit.status().message();
    if (fit->term_resolved) continue;
    ++unresolved;
    EXPECT_EQ(fit->term_norm_ci95[0], 0.0) << "seed " << seed << ": [" << fit->term_norm_ci95[0] << ", "
                                           << fit->term_norm_ci95[1] << "], largest |t| " << fit->term_max_abs_t;
  }
  EXPECT_GE(unresolved, 30);
}

TEST(FlightFit, GivenAConstantCurrentOrNone_WhenFitted_ThenTheOffsetAloneIsFittedAndTheNoteSaysWhy) {
  const SynthFlight f;
  auto samples = Fly(f, 7, /*with_current=*/false);
  auto fit = FitFlightCompass(samples, Options(f));
  ASSERT_TRUE(fit.ok());
  EXPECT_FALSE(fit->term_fitted);
  EXPECT_NE(fit->term_note.find("current known at 0 samples"), std::string::npos) << fit->term_note;
  for (auto& s : samples) s.current_A = 12.0;
  fit = FitFlightCompass(samples, Options(f));
  ASSERT_TRUE(fit.ok());
  EXPECT_FALSE(fit->term_fitted);
  EXPECT_NE(fit->term_note.find("needs 3.0 A"), std::string::npos) << fit->term_note;
}

TEST(FlightFit, GivenACurrentMissingOnTheFirstRows_WhenFitted_ThenThoseRowsAreSkippedAndTheTermIsStillFitted) {
  // A power monitor that starts a few seconds into the log: its first rows have no current.
  const SynthFlight f;
  auto samples = Fly(f, 21);
  for (size_t i = 0; i < 60; ++i) samples[i].current_A = std::nan("");
  auto fit = FitFlightCompass(samples, Options(f));
  ASSERT_TRUE(fit.ok()) << fit.status().message();
  ASSERT_TRUE(fit->term_fitted) << fit->term_note;
  EXPECT_EQ(fit->without_regressor, 60);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(fit->term_uT(k), f.d_uT_per_A(k), fit->term_ci_half_uT(k) + 1e-9);
  EXPECT_EQ(fit->used[10], 0);
}

TEST(FlightFit, GivenAFieldDrivenByThrottle_WhenFittedInThrottleForm_ThenItsFieldPerUnitThrottleIsInsideItsInterval) {
  // ArduPilot's COMPASS_MOTCT 1 form for a log without a usable current: B = d·u, u in 0..1.
  const SynthFlight f;
  auto samples = Fly(f, 5, /*with_current=*/false);
  const Vector3d d_uT(2.0, -6.0, 4.0);  // 80 mG at full throttle: inside throttle_hard_iron's 0..60 uT
  for (auto& s : samples) {
    const double u = 0.5 + 0.15 * std::sin(s.t_s / 4.0);
    s.throttle = u;
    s.y_uT += d_uT * u;
  }
  FlightFitOptions o = Options(f);
  o.form = FlightTermForm::kThrottle;
  auto fit = FitFlightCompass(samples, o);
  ASSERT_TRUE(fit.ok()) << fit.status().message();
  ASSERT_TRUE(fit->term_fitted) << fit->term_note;
  EXPECT_TRUE(fit->term_resolved);
  EXPECT_EQ(fit->form, FlightTermForm::kThrottle);
  EXPECT_LE(d_uT.norm(), fit->term_norm_ci95[1]);
  EXPECT_GE(d_uT.norm(), fit->term_norm_ci95[0]);
}

TEST(FlightFit, GivenTooFewSamplesOrANonFiniteOne_WhenFitted_ThenBadInputNamesTheMinimum) {
  const SynthFlight f;
  auto samples = Fly(f, 3);
  samples.resize(20);
  auto fit = FitFlightCompass(samples, Options(f));
  ASSERT_FALSE(fit.ok());
  EXPECT_EQ(fit.status().code(), StatusCode::kBadInput);
  EXPECT_NE(fit.status().message().find("needs at least 30"), std::string::npos) << fit.status().message();
  samples = Fly(f, 3);
  samples[5].y_uT(1) = std::nan("");
  fit = FitFlightCompass(samples, Options(f));
  ASSERT_FALSE(fit.ok());
  EXPECT_EQ(fit.status().code(), StatusCode::kBadInput);
}

TEST(FlightFit, GivenAFewWildSamples_WhenFitted_ThenTheyAreDroppedAndTheOffsetHolds) {
  const SynthFlight f;
  auto samples = Fly(f, 11);
  for (size_t i = 100; i < samples.size(); i += 150) samples[i].y_uT += Vector3d(40.0, -30.0, 25.0);
  auto fit = FitFlightCompass(samples, Options(f));
  ASSERT_TRUE(fit.ok());
  EXPECT_GE(fit->outliers, 9);
  EXPECT_LT((fit->offset_y_uT - f.offset_uT).norm(), 1.0);
}

// A term whose every axis is 0.9 of its half-width from 0 has a length 1.56 half-widths: the delta
// method's |d| - h excluded 0 (an external compass at 1-2 Hz without a field read 0.3 [0.04, 0.6]
// mG/A); an axis clear of 0 and resolved keeps the delta-method bound.
TEST(FlightFit, GivenATermWhoseEveryAxisHoldsZero_WhenItsNormIntervalIsTaken_ThenItStartsAtZero) {
  const int blocks = 9;
  const double se = 0.1 / StudentT975(blocks - 1.0);  // per-axis half-width 0.1
  const Eigen::Matrix3d cov = se * se * Eigen::Matrix3d::Identity();
  const TermNorm tn = TermNormOf(Eigen::Vector3d(0.09, -0.09, 0.09), cov, blocks);
  EXPECT_FALSE(tn.resolved);
  EXPECT_EQ(tn.ci95[0], 0.0);
  EXPECT_NEAR(tn.ci95[1], std::sqrt(3.0) * 0.09 + 0.1, 1e-12);
  const Eigen::Vector3d clear(0.6, -0.09, 0.09);  // |t| 13.8 on x
  const TermNorm tc = TermNormOf(clear, cov, blocks);
  EXPECT_TRUE(tc.resolved);
  EXPECT_NEAR(tc.ci95[0], clear.norm() - 0.1, 1e-12);
}

// One axis resolved (x: 2.5 with se 0.5, |t| 5) beside a poorly resolved one (y: 1.0 with se 3): the
// delta method's |d| - h is below 0 (h 2.8 along d), so the interval read [0, 5.5] for a field the
// three-axis test resolves (a public log: "2.5 mG/A [0.0, 5.8] ... written as the compensation").
// |d| >= |d_x|, so the low end is at least x's own: 2.5 - t975·0.5.
TEST(FlightFit, GivenOneAxisResolvedBesideAPoorlyResolvedOne_WhenItsNormIntervalIsTaken_ThenItStartsAtThatAxissLowEnd) {
  const int blocks = 9;
  const Eigen::Matrix3d cov = Eigen::Vector3d(0.25, 9.0, 0.01).asDiagonal();
  const Eigen::Vector3d d(2.5, 1.0, 0.0);
  const TermNorm tn = TermNormOf(d, cov, blocks);
  EXPECT_TRUE(tn.resolved);
  EXPECT_NEAR(tn.ci95[0], 2.5 - StudentT975(blocks - 1.0) * 0.5, 1e-12);
  EXPECT_GT(tn.ci95[0], 0.0);
  EXPECT_LE(tn.ci95[0], d.norm());
  EXPECT_GT(tn.ci95[1], d.norm());
}

// 10 Hz samples over 150 s (the slow yaw sweep and manoeuvres of Fly) with a current swinging at
// 0.3-0.7 Hz (throttle bursts) whose field the compass sees at once, and the current logged stale_s
// late, given to the fit at the trial shifts 0, 0.05, ..., 0.4 s: member m holds the logged current
// at t + shift_m.
std::vector<FlightFitSample> FlyStaleCurrent(const SynthFlight& f, uint64_t seed, double stale_s, RegressorMembers* m) {
  auto current = [](double t) {
    return 15.0 + 5.0 * std::sin(2 * M_PI * 0.45 * t) + 3.0 * std::sin(2 * M_PI * 0.31 * t + 1.0) +
           2.0 * std::sin(2 * M_PI * 0.7 * t + 2.0);
  };
  SynthFlight g = f;
  g.d_uT_per_A.setZero();
  std::vector<FlightFitSample> s = Fly(g, seed);
  for (FlightFitSample& x : s) x.y_uT += f.d_uT_per_A * current(x.t_s);
  m->shift_s.clear();
  m->value.clear();
  for (int k = 0; k <= 8; ++k) {
    m->shift_s.push_back(0.05 * k);
    std::vector<double> v;
    v.reserve(s.size());
    for (const FlightFitSample& x : s) v.push_back(current(x.t_s + 0.05 * k - stale_s));  // logged(t) = I(t − stale)
    m->value.push_back(std::move(v));
  }
  return s;
}

// The current's staleness profiled by the fit's own objective: the member at the staleness is chosen,
// and the field's interval covers the truth; the plain fit on that member gives the same point.
TEST(FlightFit, GivenAStaleCurrentAtTrialShifts_WhenProfiled_ThenTheStalenessIsChosenAndTheFieldIsCovered) {
  const SynthFlight f;
  int chosen = 0, covered = 0;
  const int seeds = 10;
  for (int seed = 1; seed <= seeds; ++seed) {
    RegressorMembers m;
    std::vector<FlightFitSample> s = FlyStaleCurrent(f, 40 + static_cast<uint64_t>(seed), 0.2, &m);
    auto fit = FitFlightCompassProfiled(s, m, Options(f));
    ASSERT_TRUE(fit.ok()) << fit.status().message();
    ASSERT_TRUE(fit->term_fitted);
    EXPECT_EQ(fit->regressor_members, 9);
    chosen += std::fabs(fit->regressor_shift_s - 0.2) < 1e-9;
    const double truth = f.d_uT_per_A.norm();
    covered += fit->term_norm_ci95[0] <= truth && truth <= fit->term_norm_ci95[1];
    EXPECT_LE(fit->regressor_shift_range_s[0], fit->regressor_shift_s);
    EXPECT_GE(fit->regressor_shift_range_s[1], fit->regressor_shift_s);
    // The plain fit on the chosen member: the same point.
    const auto k = static_cast<size_t>(std::lround(fit->regressor_shift_s / 0.05));
    for (size_t i = 0; i < s.size(); ++i) s[i].current_A = m.value[k][i];
    auto plain = FitFlightCompass(s, Options(f));
    ASSERT_TRUE(plain.ok());
    EXPECT_NEAR((plain->term_uT - fit->term_uT).norm(), 0.0, 1e-9);
  }
  EXPECT_GE(chosen, seeds * 8 / 10);
  EXPECT_GE(covered, seeds * 8 / 10);
}

// A current that changes slowly (Fly's, over tens of seconds) tells its shift poorly: the
// delete-one-block fits choose different members, and the interval holds that choice (wider than the
// chosen member's own interval, which takes the shift as known).
TEST(FlightFit, GivenAShiftTheDataTellPoorly_WhenProfiled_ThenTheIntervalHoldsTheChoice) {
  SynthFlight f;
  f.noise_uT = 2.0;
  int spread = 0, wider = 0;
  const int seeds = 10;
  for (int seed = 1; seed <= seeds; ++seed) {
    std::vector<FlightFitSample> s = Fly(f, 60 + static_cast<uint64_t>(seed));
    RegressorMembers m;
    for (int k = 0; k <= 10; ++k) {
      m.shift_s.push_back(0.1 * k);
      std::vector<double> v;
      v.reserve(s.size());
      for (const FlightFitSample& x : s) {
        const double t = x.t_s + 0.1 * k - 0.3;  // logged 0.3 s late
        v.push_back(14.0 + 6.0 * std::sin(t / 7.0) * std::cos(t / 2.3));
      }
      m.value.push_back(std::move(v));
    }
    auto fit = FitFlightCompassProfiled(s, m, Options(f));
    ASSERT_TRUE(fit.ok()) << fit.status().message();
    const auto k = static_cast<size_t>(std::lround(fit->regressor_shift_s / 0.1));
    for (size_t i = 0; i < s.size(); ++i) s[i].current_A = m.value[k][i];
    auto fixed = FitFlightCompass(s, Options(f));
    ASSERT_TRUE(fixed.ok());
    const bool chose_several = fit->regressor_shift_range_s[1] > fit->regressor_shift_range_s[0];
    spread += chose_several;
    const double w = fit->term_norm_ci95[1] - fit->term_norm_ci95[0];
    const double w_fixed = fixed->term_norm_ci95[1] - fixed->term_norm_ci95[0];
    wider += chose_several && w > w_fixed;
  }
  EXPECT_GE(spread, seeds / 2);
  EXPECT_EQ(wider, spread);
}

// Members that do not match the samples are bad input.
TEST(FlightFit, GivenMembersThatDoNotMatchTheSamples_WhenProfiled_ThenBadInput) {
  const SynthFlight f;
  RegressorMembers m;
  std::vector<FlightFitSample> s = FlyStaleCurrent(f, 3, 0.1, &m);
  m.value[2].pop_back();
  auto fit = FitFlightCompassProfiled(s, m, Options(f));
  ASSERT_FALSE(fit.ok());
  EXPECT_EQ(fit.status().code(), StatusCode::kBadInput);
  FlyStaleCurrent(f, 3, 0.1, &m);
  std::swap(m.shift_s[0], m.shift_s[1]);
  EXPECT_FALSE(FitFlightCompassProfiled(s, m, Options(f)).ok());
}

}  // namespace
}  // namespace hexsim::magnetics
