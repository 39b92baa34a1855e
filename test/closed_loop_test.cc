// GIVEN a vehicle and a mission, WHEN flown closed-loop on the true state (the controller reads
// truth; estimators are tested in closed_loop_nav_test), THEN the mission completes and lands.
#include <gtest/gtest.h>

#include "hexsim/sim/run_config.h"
#include "hexsim/sim/simulation.h"

namespace hexsim::sim {
namespace {

RunOutput Fly(const std::string& mission, const std::string& vehicle, const std::string& world,
              std::vector<std::string> sets = {}) {
  RunRequest req;
  req.mission = mission;
  req.vehicle = vehicle;
  req.world = world;
  req.estimator = "truth";
  req.seed = 11;
  req.sets = std::move(sets);
  auto setup = LoadRunSetup(req);
  EXPECT_TRUE(setup.ok()) << setup.status().message();
  return RunMission(*setup);
}

TEST(ClosedLoop, GivenCalmAirWhenTheSquareIsFlownThenItCompletesWithCrossTrackUnderHalfAMetreAndLands) {
  for (const char* vehicle : {"default_hex", "paper_hex", "quad_x"}) {
    const RunOutput out = Fly("square", vehicle, "default");
    ASSERT_TRUE(out.status.ok()) << out.status.message();
    const auto& s = out.summary;
    EXPECT_EQ(s.status, RunStatus::kCompleted) << vehicle << ": " << s.reason;
    EXPECT_LT(s.cross_track_m.rms, 0.5) << vehicle;
    EXPECT_EQ(s.waypoints.size(), 4u) << vehicle;
    // Landed: back on the ground (CG at the gear height), still.
    const auto& d = out.log.Column("pos_D_m");
    const auto& vd = out.log.Column("vel_D_mps");
    EXPECT_GT(d.back(), -0.3) << vehicle;
    EXPECT_LT(std::abs(vd.back()), 0.05) << vehicle;
    // Took off: reached the mission altitude (10 m) on the way.
    double min_d = 0;
    for (double x : d) min_d = std::min(min_d, x);
    EXPECT_LT(min_d, -9.5) << vehicle;
  }
}

TEST(ClosedLoop, GivenAPayloadReleasedMidFlightWhenFlownThenMassDropsAndTheMissionCompletes) {
  const RunOutput out = Fly("payload_change", "paper_hex", "changchun");
  EXPECT_EQ(out.summary.status, RunStatus::kCompleted) << out.summary.reason;
  const auto& payload = out.log.Column("payload_kg");
  EXPECT_GT(payload.front(), 0.0);
  EXPECT_EQ(payload.back(), 0.0);
  // Releasing the payload lowers the hover current.
  const auto& current = out.log.Column("current_A");
  const auto& mode = out.log.Column("mode");
  double before = 0, after = 0;
  int nb = 0, na = 0;
  for (size_t i = 0; i < payload.size(); ++i) {
    if (mode[i] != 2 && mode[i] != 3) continue;  // waypoint / hold
    if (payload[i] > 0) {
      before += current[i];
      ++nb;
    } else {
      after += current[i];
      ++na;
    }
  }
  ASSERT_GT(nb, 100);
  ASSERT_GT(na, 100);
  EXPECT_GT(before / nb, 1.1 * (after / na));
}

TEST(ClosedLoop, GivenWindWhenTheSquareIsFlownThenItStillCompletes) {
  const RunOutput out = Fly("square", "default_hex", "windy");
  EXPECT_EQ(out.summary.status, RunStatus::kCompleted) << out.summary.reason;
  EXPECT_LT(out.summary.cross_track_m.rms, 1.5);
}

TEST(ClosedLoop, GivenAnAbsurdGainWhenFlownThenTheMissionFailsWithoutNonFiniteNumbers) {
  // Saturated rotors bound the torque, so an absurd gain tumbles the vehicle rather than blowing
  // up the numbers: the run ends as not completed, with a finite log.
  const RunOutput out = Fly("square", "default_hex", "default", {"control.rate.roll.kp=1e7", "control.rate.roll.output_limit=1e9", "sim.max_duration_s=120"});
  EXPECT_EQ(out.summary.status, RunStatus::kNotCompleted);
  for (size_t c = 0; c < out.log.columns().size(); ++c) {
    for (double v : out.log.Column(c)) ASSERT_FALSE(std::isinf(v));
  }
}

TEST(ClosedLoop, GivenAnAbsurdInertiaWhenFlownThenTheRunStopsAsDivergedNamingQuantityAndTime) {
  const RunOutput out = Fly("square", "default_hex", "default", {"vehicle.inertia_kgm2=[1e-9, 1e-9, 1e-9]"});
  EXPECT_EQ(out.summary.status, RunStatus::kDiverged);
  EXPECT_EQ(out.status.code(), StatusCode::kNumerical);
  const std::string reason = out.summary.reason;
  EXPECT_NE(reason.find(" at t = "), std::string::npos) << reason;
  // The log stops at the divergence and holds no non-finite number.
  for (size_t c = 0; c < out.log.columns().size(); ++c) {
    for (double v : out.log.Column(c)) ASSERT_FALSE(std::isinf(v));
  }
}

}  // namespace
}  // namespace hexsim::sim
