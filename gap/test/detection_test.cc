// Library-free detection's spike test (gap/src/detection.h, test (3)) and the FFT its spectral tests use
// (gap/src/spectrum.h), on series built here.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "../src/detection.h"
#include "../src/spectrum.h"
#include "hexsim/common/rng.h"

namespace hexsim::gap {
namespace {

using internal::Vec3;

std::vector<Vec3> WhiteNoise(size_t n, double sigma, uint64_t seed) {
  RngStream rng(seed, "detection_test");
  std::vector<Vec3> r(n);
  for (auto& v : r) v = rng.Normal3(sigma);
  return r;
}

TEST(GapSpikes, GivenWhiteNoise_WhenCounted_ThenNoSpikeIsFound) {
  for (uint64_t seed = 1; seed <= 5; ++seed) EXPECT_EQ(internal::CountSpikes(WhiteNoise(2000, 0.3, seed)), 0);
}

TEST(GapSpikes, GivenThreeIsolatedDepartures_WhenCounted_ThenEachIsASpike) {
  std::vector<Vec3> r = WhiteNoise(2000, 0.3, 7);
  r[100].x() += 12.0;   // 40 sigma
  r[900].z() -= 10.0;
  r[1500].y() += 20.0;
  EXPECT_EQ(internal::CountSpikes(r), 3);
  std::vector<double> t(r.size());
  for (size_t k = 0; k < t.size(); ++k) t[k] = 0.1 * static_cast<double>(k);
  const internal::Structure s = internal::DetectStructure(t, r, 0.0, 0.1, 1.0, 0.0, 0.01);
  EXPECT_TRUE(s.present);
  EXPECT_EQ(s.spikes, 3);
}

TEST(GapSpikes, GivenAStepOrADepartureBelowTheBound_WhenCounted_ThenItIsNoSpike) {
  std::vector<Vec3> r = WhiteNoise(2000, 0.3, 8);
  for (size_t k = 1000; k < r.size(); ++k) r[k].x() += 8.0;  // a step leaves one neighbour only
  r[500].y() += 4.0;                                           // about 11 sigma: a replay transient's size
  EXPECT_EQ(internal::CountSpikes(r), 0);
}

// FourierPower (gap/src/spectrum.h) against the direct sum it replaces, at lengths that take each
// path: a power of two (radix 2), a prime and composite lengths (Bluestein).
TEST(GapSpectrum, GivenSeriesOfAnyLength_WhenTransformed_ThenThePowerEqualsTheDirectSum) {
  for (size_t m : {2, 3, 64, 97, 100, 1000, 1021}) {
    const std::vector<Vec3> x = WhiteNoise(m, 1.0, 11 + m);
    const std::vector<double> fast = internal::FourierPower(x);
    ASSERT_EQ(fast.size(), m / 2) << m;
    double total = 0;
    for (double p : fast) total += p;
    for (size_t f = 1; f <= m / 2; ++f) {
      Vec3 re = Vec3::Zero(), im = Vec3::Zero();
      for (size_t k = 0; k < m; ++k) {
        const double w = 2.0 * 3.141592653589793 * static_cast<double>(f * k % m) / static_cast<double>(m);
        re += x[k] * std::cos(w);
        im -= x[k] * std::sin(w);
      }
      EXPECT_NEAR(fast[f - 1], re.squaredNorm() + im.squaredNorm(), 1e-9 * total) << "m " << m << " f " << f;
    }
  }
}

TEST(GapSpectrum, GivenASineInNoise_WhenDetected_ThenTheLineIsAtItsFrequency) {
  std::vector<Vec3> r = WhiteNoise(3001, 0.3, 12);  // a prime length: the Bluestein path
  std::vector<double> t(r.size());
  for (size_t k = 0; k < t.size(); ++k) {
    t[k] = 0.1 * static_cast<double>(k);
    r[k].y() += 0.5 * std::sin(2.0 * 3.141592653589793 * 0.37 * t[k]);
  }
  const internal::Structure s = internal::DetectStructure(t, r, 0.0, 0.1, 1.0, 0.0, 0.01);
  EXPECT_TRUE(s.present);
  EXPECT_NEAR(s.line_freq_Hz, 0.37, 1.0 / 300.1);
}

}  // namespace
}  // namespace hexsim::gap
