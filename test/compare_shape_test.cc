// GIVEN the paper's hex flying the climb-and-cruise square on its ESKF estimate, WHEN flown with the
// traditional (ground ellipsoid) and the adaptive (paper) calibration, each learnt on the simulated
// turntable, THEN the flight shows the paper's finding (its Figs. 8–9: yaw error up to 15° → < 3°).
#include <gtest/gtest.h>

#include "hexsim/experiments/point_runner.h"
#include "hexsim/sim/run_config.h"
#include "hexsim/sim/simulation.h"

namespace hexsim::sim {
namespace {

struct Flight {
  double yaw_max_deg = 0, yaw_rms_deg = 0, xtrack_rms_m = 0;
  std::string status;
};

Flight Fly(const std::string& method, uint64_t seed) {
  RunRequest req;
  req.mission = "climb_cruise_square";
  req.vehicle = "paper_hex";
  req.world = "changchun";
  req.seed = seed;
  auto setup = LoadRunSetup(req);
  EXPECT_TRUE(setup.ok()) << setup.status().message();
  // The calibration learnt on the ground session of this seed, as `hexsim compare` does.
  auto flown = experiments::FlyPoint(std::move(*setup), method);
  EXPECT_TRUE(flown.ok()) << flown.status().message();
  const RunOutput& out = *flown;
  Flight f;
  f.status = RunStatusName(out.summary.status);
  f.yaw_max_deg = out.summary.yaw_error_deg.max;
  f.yaw_rms_deg = out.summary.yaw_error_deg.rms;
  f.xtrack_rms_m = out.summary.cross_track_m.rms;
  return f;
}

TEST(CompareShape, GivenPaperHexOnItsEstimateWhenCalibratedTraditionallyOrAdaptivelyThenAdaptiveKeepsYawAndTrack) {
  double trad_max = 0, adapt_max = 0, trad_xt = 0, adapt_xt = 0;
  const int seeds = 3;
  for (int s = 1; s <= seeds; ++s) {
    const Flight t = Fly("traditional", s), a = Fly("adaptive", s);
    EXPECT_EQ(t.status, "completed") << "seed " << s;
    EXPECT_EQ(a.status, "completed") << "seed " << s;
    // The paper's traditional calibration reaches ~15 deg in flight; with the powertrain's ESC and
    // battery limits and spool-up the current no longer spikes to 2.6x its mean at spin-up (legs'
    // peak 140 -> 81 A), so the traditional worst case here is 7.3-8.3 deg: several times the
    // adaptive one is the shape that matters, plus a floor well above the adaptive's 3 deg.
    EXPECT_GE(t.yaw_max_deg, 6.0) << "traditional, seed " << s;
    EXPECT_GE(t.yaw_max_deg, 2.5 * a.yaw_max_deg) << "seed " << s;
    EXPECT_LT(a.yaw_rms_deg, 1.5) << "adaptive, seed " << s;
    EXPECT_LT(a.yaw_rms_deg, 0.5 * t.yaw_rms_deg) << "seed " << s;
    trad_max += t.yaw_max_deg / seeds;
    adapt_max += a.yaw_max_deg / seeds;
    trad_xt += t.xtrack_rms_m / seeds;
    adapt_xt += a.xtrack_rms_m / seeds;
  }
  EXPECT_LT(adapt_max, 3.0);
  EXPECT_LT(adapt_max, 0.5 * trad_max);
  EXPECT_LT(adapt_xt, 0.85 * trad_xt);
}

}  // namespace
}  // namespace hexsim::sim
