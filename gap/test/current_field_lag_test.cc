// The current-driven field's lag behind the logged current under timing (ScanCurrentFieldLag): a
// field that lags the logged current and grows faster than linearly, on top of the wires' own
// field (which follows the current without a lag, in another direction), has its lag measured with an
// interval holding it; a field without a lag has no lag resolved; the lag's state runs over the
// current's whole history, not from the first diagnosed sample.
#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "../src/channels.h"
#include "../src/nuisance.h"
#include "hexsim/common/rng.h"

namespace hexsim::gap {
namespace {

// A logged current at 10 Hz over `seconds` (a hover around 15 A, climbs and descents of a few amperes
// every few seconds, sensor noise).
struct Current {
  std::vector<double> t, I;
};

Current MakeCurrent(double seconds, uint64_t seed) {
  RngStream rng(seed, "current_field_lag/current");
  Current c;
  double level = 15.0, target = 15.0;
  for (int k = 0; k * 0.1 <= seconds; ++k) {
    if (k % 30 == 0) target = 15.0 + 6.0 * (rng.Uniform() - 0.5);
    level += 0.3 * (target - level);
    c.t.push_back(0.1 * k);
    c.I.push_back(level + 0.4 * rng.Normal());
  }
  return c;
}

// The channel of a compass sampled at 10 Hz from t0 on (the diagnosed window), its residual the
// wires' field a·I plus, where tau > 0, d·I0·(lp_τ(I)/I0)^1.6, plus 0.5 µT noise; the baseline's
// columns an offset and a slowly turning field (the vehicle yawing). The caller points in.current
// at cur.I (a usable current).
struct LagChannel {
  internal::ChannelData ch;
  internal::LogInputs in;
  Current cur;
};

LagChannel MakeChannel(double tau, double t0, uint64_t seed) {
  LagChannel s;
  s.cur = MakeCurrent(t0 + 240.0, seed);
  s.in.current_samples_t = s.cur.t;
  s.in.current_samples_v = s.cur.I;
  RngStream rng(seed, "current_field_lag/noise");
  const Eigen::Vector3d a(0.6, -0.4, 0.5), d(-0.3, 0.45, 0.2);
  const double I0 = 15.0;
  const Current& c = s.cur;
  double lagged = c.I.front();
  size_t j = 0;
  for (double t = t0; t < c.t.back() - 0.2; t += 0.1) {
    // The truth's lag by a fine Euler integration of τ·ẏ = I − y (independent of the scan's own
    // discretisation), forward from the previous sample.
    if (tau > 0) {
      for (; j * 0.002 < t; ++j) {
        const double s_t = j * 0.002;
        const size_t i = std::min(c.t.size() - 2, static_cast<size_t>(std::floor(s_t / 0.1)));
        const double w = std::clamp((s_t - c.t[i]) / 0.1, 0.0, 1.0);
        lagged += 0.002 / tau * ((1 - w) * c.I[i] + w * c.I[i + 1] - lagged);
      }
    }
    const size_t i = static_cast<size_t>(std::floor(t / 0.1));
    const double w = (t - c.t[i]) / 0.1;
    const double I = (1 - w) * c.I[i] + w * c.I[i + 1];
    Eigen::Vector3d y = a * I + 0.5 * Eigen::Vector3d(rng.Normal(), rng.Normal(), rng.Normal());
    if (tau > 0) y += d * I0 * std::pow(lagged / I0, 1.6);
    const Eigen::Matrix3d R = Eigen::AngleAxisd(0.05 * t, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    internal::Mat3X x(3, 6);
    x << Eigen::Matrix3d::Identity(), R;
    s.ch.t.push_back(t);
    s.ch.y.push_back(y);
    s.ch.current_A.push_back(I);
    s.ch.baseline.X.push_back(x);
  }
  return s;
}

// Given a field lagging the logged current by 0.5 s and growing as its 1.6th power, beside the wires'
// unlagged field in another direction, when the lag is scanned, then its interval holds 0.5 s and
// is resolved from zero.
TEST(GapCurrentFieldLag, GivenALaggedPowerLawFieldBesideTheWiresField_WhenScanned_ThenItsIntervalHoldsTheLag) {
  for (uint64_t seed = 1; seed <= 3; ++seed) {
    LagChannel s = MakeChannel(0.5, 30.0, seed);
    s.in.current = &s.cur.I;
    const LagReport l = internal::ScanCurrentFieldLag(s.ch, s.in, 0.0, DiagnoseOptions{});
    ASSERT_TRUE(l.present);
    EXPECT_EQ(l.against, "current_A");
    EXPECT_LE(l.ci95_s.lo, 0.5) << seed;
    EXPECT_GE(l.ci95_s.hi, 0.5) << seed;
    EXPECT_TRUE(l.resolved && l.plausible) << seed << ": " << l.ci95_s.lo << ".." << l.ci95_s.hi;
    EXPECT_LT(l.ci95_s.hi - l.ci95_s.lo, 0.5) << seed;
  }
}

// Given only the wires' unlagged field, when the lag is scanned, then no lag is resolved.
TEST(GapCurrentFieldLag, GivenOnlyTheWiresUnlaggedField_WhenScanned_ThenNoLagIsResolved) {
  for (uint64_t seed = 1; seed <= 3; ++seed) {
    LagChannel s = MakeChannel(0.0, 30.0, seed);
    s.in.current = &s.cur.I;
    const LagReport l = internal::ScanCurrentFieldLag(s.ch, s.in, 0.0, DiagnoseOptions{});
    ASSERT_TRUE(l.present);
    EXPECT_FALSE(l.resolved) << seed << ": " << l.value_s << " [" << l.ci95_s.lo << ", " << l.ci95_s.hi << "]";
  }
}

// Given a channel without a usable current, when the lag is scanned, then nothing is reported.
TEST(GapCurrentFieldLag, GivenNoUsableCurrent_WhenScanned_ThenNoLagIsReported) {
  const LagChannel s = MakeChannel(0.5, 30.0, 1);  // its `current` left null
  EXPECT_FALSE(internal::ScanCurrentFieldLag(s.ch, s.in, 0.0, DiagnoseOptions{}).present);
}

}  // namespace
}  // namespace hexsim::gap
