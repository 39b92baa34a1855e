// Powertrain limits in closed loop (issue 20): GIVEN the shipped vehicles with their ESC current
// limits, battery ratings and spool-up, WHEN the shipped missions are flown, THEN no ESC and no
// battery ever draws more than its limit; on the paper's mission the battery's peak current stays
// within 2.5x its mean (no spin-up or take-off surge); and a deliberately tight ESC limit saturates
// and costs tracking, without the flight diverging.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "hexsim/experiments/point_runner.h"
#include "hexsim/sim/run_config.h"
#include "hexsim/sim/simulation.h"

namespace hexsim::sim {
namespace {

RunSetup MakeSetup(const std::string& mission, const std::string& vehicle, const std::string& estimator,
                   std::vector<std::string> sets = {}, const std::string& world = "changchun", uint64_t seed = 3) {
  RunRequest req;
  req.mission = mission;
  req.vehicle = vehicle;
  req.world = world;  // by default the paper's site, as `hexsim compare` flies it
  req.estimator = estimator;
  req.seed = seed;
  req.sets = std::move(sets);
  req.sets.emplace_back("sim.write_log=false");
  auto setup = LoadRunSetup(req);
  HEXSIM_CHECK(setup.ok());
  return *setup;
}

struct Watched {
  double esc_max_A = 0.0;      // largest ESC input current over every step
  double battery_max_A = 0.0;  // largest battery current
  double max_tilt_deg = 0.0;
  double end_s = 0.0;
  RunSummary summary;
};

// Flies step by step, watching the powertrain's operating point at every physics step.
Watched FlyWatching(const RunSetup& setup) {
  auto sim = Simulation::Create(setup);
  HEXSIM_CHECK(sim.ok());
  Watched w;
  while ((*sim)->Step()) {
    const vehicle::PowertrainOutput& pt = (*sim)->powertrain();
    for (const vehicle::MotorOperatingPoint& m : pt.motors) w.esc_max_A = std::max(w.esc_max_A, m.dc_A);
    w.battery_max_A = std::max(w.battery_max_A, pt.battery_A);
    const Eigen::Vector3d z_B_N = (*sim)->true_state().q_NB * Eigen::Vector3d::UnitZ();
    w.max_tilt_deg = std::max(w.max_tilt_deg, std::acos(std::clamp(z_B_N.z(), -1.0, 1.0)) * 180.0 / M_PI);
  }
  w.end_s = (*sim)->time_s();
  w.summary = (*sim)->Finish().summary;
  return w;
}

// One test per shipped vehicle and mission (each under ~4 s: calm, then windy).
class ShippedPair : public ::testing::TestWithParam<std::tuple<const char*, const char*>> {};

TEST_P(ShippedPair, GivenTheVehiclesLimitsWhenTheShippedMissionIsFlownThenNoEscOrBatteryExceedsThemAndItLandsInWind) {
  const auto [vehicle_name, mission] = GetParam();
  // Every shipped mission is at most ~150 s long; a pair that cannot complete (default_hex cannot
  // lift payload_pickup_drop's 3 kg) still must not exceed its limits, so the cap is 200 s.
  const RunSetup setup = MakeSetup(mission, vehicle_name, "truth", {"sim.max_duration_s=200"});
  const vehicle::VehicleParams& v = setup.vehicle;
  ASSERT_TRUE(std::isfinite(v.esc.current_limit_A)) << vehicle_name << ": shipped without an ESC limit";
  ASSERT_TRUE(std::isfinite(v.battery.max_current_A)) << vehicle_name << ": shipped without a battery rating";
  const Watched w = FlyWatching(setup);
  EXPECT_NE(w.summary.status, RunStatus::kDiverged) << w.summary.reason;
  // The limiters solve their equations to round-off: 1e-9 relative is the solver's tolerance.
  EXPECT_LE(w.esc_max_A, v.esc.current_limit_A * (1.0 + 1e-9));
  EXPECT_LE(w.battery_max_A, v.battery.max_current_A * (1.0 + 1e-9));
  EXPECT_GT(w.battery_max_A, 2.0 * v.avionics_current_A);  // the motors ran
  if (w.summary.status != RunStatus::kCompleted) return;  // a payload it cannot lift: no landing to check

  // In the windiest shipped world (5 m/s mean, 0.8 m/s turbulence), on the estimator with the compass
  // calibrated (adaptive), it completes and lands within 60 s of its last waypoint. Seed 46 is the
  // one users reported: its height estimate is 1.8 m low, and the landing used to stop at its
  // carrot's end 1 m below the estimated ground and hover until gusts let a "still" touchdown
  // through (65-136 s after the last waypoint for 5 of these pairs, or the 900 s cap).
  auto windy = experiments::FlyPoint(
      MakeSetup(mission, vehicle_name, "", {"sim.max_duration_s=300"}, "windy", /*seed=*/46), "adaptive");
  ASSERT_TRUE(windy.ok()) << windy.status().message();
  const RunSummary& s = windy->summary;
  ASSERT_EQ(s.status, RunStatus::kCompleted) << s.reason;
  ASSERT_FALSE(s.waypoints.empty());
  ASSERT_TRUE(s.mission_time_s.has_value());
  EXPECT_LE(*s.mission_time_s - s.waypoints.back().arrival_time_s, 60.0) << "landing took too long";
}

// The shipped missions (worlds/missions/*.yaml); a test below checks this list is complete.
constexpr const char* kMissions[] = {"climb_cruise_square", "figure_eight", "lawnmower", "payload_change",
                                     "payload_pickup_drop", "selftest_flight", "square"};

INSTANTIATE_TEST_SUITE_P(Shipped, ShippedPair,
                         ::testing::Combine(::testing::Values("paper_hex", "default_hex", "quad_x"),
                                            ::testing::ValuesIn(kMissions)));

TEST(PowerLimits, GivenTheMissionsFolderWhenListedThenEveryShippedMissionIsFlownAbove) {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(std::string(HEXSIM_SOURCE_DIR) + "/worlds/missions")) {
    if (e.path().extension() == ".yaml") names.push_back(e.path().stem().string());
  }
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, std::vector<std::string>(std::begin(kMissions), std::end(kMissions)));
}

// The paper's mission on the paper's hex, flown on the estimate with its compass calibrated
// (adaptive, as the paper flies it): take-off included, the peak battery current stays within 2.5x
// the mission's mean. Before the spool-up, take-off ramp and ESC limits it was 5x (277 A vs 53 A).
TEST(PowerLimits, GivenThePaperMissionWhenFlownThenThePeakBatteryCurrentStaysWithinTwoAndAHalfTimesItsMean) {
  RunSetup setup = MakeSetup("climb_cruise_square", "paper_hex", "");
  auto out = experiments::FlyPoint(std::move(setup), "adaptive");
  ASSERT_TRUE(out.ok()) << out.status().message();
  const RunSummary& s = out->summary;
  EXPECT_EQ(s.status, RunStatus::kCompleted) << s.reason;
  EXPECT_LE(s.current_max_A, 2.5 * s.current_mean_A) << s.current_max_A << " A vs mean " << s.current_mean_A;
}

// A deliberately tight ESC limit: 10 A per ESC against ~8.8 A in hover (14 % headroom), so every
// climb, turn and brake saturates. The vehicle must still fly the mission (slower, further off the
// line), stay upright and land, and the summary must show the time spent limited. (At 12 A it is
// limited for 31 s of 69 s yet tracks as well as unlimited: the allocation knows the ceiling.)
TEST(PowerLimits, GivenATightEscLimitWhenThePaperMissionIsFlownThenItSaturatesAndTracksWorseWithoutDiverging) {
  const Watched free = FlyWatching(MakeSetup("climb_cruise_square", "paper_hex", "truth"));
  const Watched tight =
      FlyWatching(MakeSetup("climb_cruise_square", "paper_hex", "truth", {"vehicle.esc.current_limit_A=10"}));
  EXPECT_EQ(tight.summary.status, RunStatus::kCompleted) << tight.summary.reason;
  EXPECT_LE(tight.esc_max_A, 10.0 * (1.0 + 1e-9));
  // Saturated for much of the flight, not a blip; the battery never limits (6 x 10 A << 330 A).
  EXPECT_GT(tight.summary.current_limited_esc_s, 10.0);
  EXPECT_EQ(free.summary.current_limited_battery_s, 0.0);
  EXPECT_EQ(tight.summary.current_limited_battery_s, 0.0);
  // Tracking degrades visibly: the worst cross-track at least 3x the unlimited flight's, and the
  // mission takes at least 5 s longer.
  EXPECT_GT(tight.summary.cross_track_m.max, 3.0 * free.summary.cross_track_m.max)
      << tight.summary.cross_track_m.max << " m vs " << free.summary.cross_track_m.max << " m";
  EXPECT_GT(tight.end_s, free.end_s + 5.0);
  // Without diverging: upright throughout (tilt below the controller's 35 deg limit plus margin).
  EXPECT_LT(tight.max_tilt_deg, 50.0);
}

}  // namespace
}  // namespace hexsim::sim
