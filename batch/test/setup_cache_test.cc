#include "hexsim/batch/setup_cache.h"

#include <gtest/gtest.h>

#include "hexsim/sim/simulation.h"

namespace hexsim::batch {
namespace {

nlohmann::json SummaryWithoutWall(const sim::RunSetup& setup) {
  nlohmann::json s = sim::ToJson(sim::RunMission(setup).summary);
  s.erase("wall_s");
  return s;
}

TEST(SetupCache, GivenASetupCachedForOneSeedWhenAnotherSeedIsTakenFromItThenTheRunEqualsAFreshlyLoadedOne) {
  RunPoint p;
  p.estimator = "eskf";  // sensor noise, and so the flight, depends on the seed
  p.duration_s = 2.0;
  p.sets["world.wind.turbulence_std_mps"] = 0.5;
  p.seed = 1;
  SetupCache cache;
  ASSERT_TRUE(cache.Get(p).ok());
  p.seed = 2;
  auto cached = cache.Get(p);
  ASSERT_TRUE(cached.ok()) << cached.status().message();
  EXPECT_EQ(cache.size(), 1u);
  auto fresh = sim::LoadRunSetup(RequestFor(p));
  ASSERT_TRUE(fresh.ok()) << fresh.status().message();
  const auto a = SummaryWithoutWall(*cached);
  EXPECT_EQ(a, SummaryWithoutWall(*fresh));
  p.seed = 1;
  EXPECT_NE(a, SummaryWithoutWall(*cache.Get(p)));  // the seed did reach the run
}

TEST(SetupCache, GivenABadOverrideWhenLoadedThenTheErrorIsReturnedAndNothingIsCached) {
  RunPoint p;
  p.sets["vehicle.no_such_key_kg"] = 1;
  SetupCache cache;
  EXPECT_FALSE(cache.Get(p).ok());
  EXPECT_EQ(cache.size(), 0u);
}

}  // namespace
}  // namespace hexsim::batch
