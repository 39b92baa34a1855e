// Library-free detection's spike test (gap/src/detection.h, test (3)) on series built here.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "../src/detection.h"
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

}  // namespace
}  // namespace hexsim::gap
