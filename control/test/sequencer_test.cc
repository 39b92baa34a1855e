#include "hexsim/control/control_io.h"
#include "hexsim/control/sequencer.h"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hexsim/common/rotation.h"
#include "hexsim/common/yaml_reader.h"
#include "hexsim/control/controller.h"
#include "support/plant.h"

namespace hexsim::control {
namespace {

using Eigen::Vector3d;

Mission LoadShipped(const std::string& name) {
  const std::string path = std::string(HEXSIM_SOURCE_DIR) + "/worlds/missions/" + name + ".yaml";
  Result<YAML::Node> node = YamlReader::LoadFile(path);
  EXPECT_TRUE(node.ok()) << node.status().message();
  Result<Mission> m = ParseMission(*node, path);
  EXPECT_TRUE(m.ok()) << m.status().message();
  Result<Mission> r = ResolveMission(*m, GeoPoint{43.88, 125.35, 200.0});
  EXPECT_TRUE(r.ok());
  return *r;
}

// An ideal vehicle: exactly where the setpoint tells it, at the feed-forward speed, but stopped by
// the ground (the landing carrot aims below it); it stays put while the motors are idle.
void FollowExactly(const SequencerOutput& out, NavState* s) {
  if (out.setpoint.idle) return;
  s->p_N_m = out.setpoint.p_N_m;
  s->v_N_mps = out.setpoint.v_ff_N_mps;
  if (s->p_N_m.z() > 0.0) {
    s->p_N_m.z() = 0.0;
    s->v_N_mps.setZero();
  }
}

int CountWaypoints(const Mission& m) {
  int n = 0;
  for (const MissionItem& it : m.items) n += it.type == MissionItemType::kWaypoint;
  return n;
}

TEST(SequencerTest, GivenVehicleThatFollowsTheSetpointExactly_ThenItemsRunInOrderAndTheMissionEndsLanded) {
  const Mission m = LoadShipped("payload_change");
  MissionSequencer seq(m);
  NavState s;
  std::vector<FlightMode> modes;
  std::vector<int> arrivals;
  std::vector<PayloadEvent> events;
  const double dt = 0.01;
  for (int i = 0; i < 20000 && !seq.done(); ++i) {
    const SequencerOutput out = seq.Step(s, dt);
    if (modes.empty() || modes.back() != seq.mode()) modes.push_back(seq.mode());
    if (out.arrival) arrivals.push_back(out.arrival->waypoint_index);
    if (out.payload_event) events.push_back(*out.payload_event);
    FollowExactly(out, &s);
    s.t_s += dt;
  }
  ASSERT_TRUE(seq.done());
  EXPECT_TRUE(seq.landed());
  EXPECT_EQ(modes, (std::vector<FlightMode>{FlightMode::kTakeoff, FlightMode::kWaypoint, FlightMode::kHold,
                                            FlightMode::kWaypoint, FlightMode::kLand, FlightMode::kLanded,
                                            FlightMode::kDone}));
  EXPECT_EQ(arrivals, (std::vector<int>{0, 1, 2, 3}));
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].action, PayloadAction::kRelease);
  EXPECT_DOUBLE_EQ(events[0].mass_kg, 2.0);
  EXPECT_EQ(events[0].item_index, 3);
  EXPECT_NEAR(s.p_N_m.z(), 0.0, 1e-9);
  // Time: 10 m climb at 2.5 m/s, 120 m of legs at 5 m/s, holds 3 + 3 s, 10 m descent, touchdown
  // confirmation and the landed pause; plus accelerating and braking on each of 6 segments.
  const double lower_s = 10 / 2.5 + 120 / 5.0 + 6 + 7 / 1.2 + 3 / 0.5;
  EXPECT_GT(s.t_s, lower_s);
  EXPECT_LT(s.t_s, lower_s + 6 * 2 * 5.0 / 2.0 + 2.0 + 2.0);
}

// The autopilot runs on each fresh IMU sample: a 400 Hz IMU on a 1 ms physics step ticks at 2 and 3 ms
// alternately. The carrot's braking to a stop must still ask for at most its acceleration: a braking
// speed taken from the distance before the step (one step behind the profile) asked for accel times
// 3/2 and 2/3 on alternate ticks, a collective alternating by ~20 % at 200 Hz that a 100 Hz log aliases.
TEST(SequencerTest, GivenUnevenAutopilotTicks_WhenTheCarrotBrakes_ThenItsAccelerationNeverExceedsAccel) {
  const Mission m = LoadShipped("square");
  const SequencerParams params;
  MissionSequencer seq(m, params);
  NavState s;
  double max_a = 0.0;
  int braking_ticks = 0;
  for (int i = 0; i < 200000 && !seq.done(); ++i) {
    const double dt = i % 2 == 0 ? 0.003 : 0.002;
    const SequencerOutput out = seq.Step(s, dt);
    if (!out.setpoint.idle) {
      max_a = std::max(max_a, out.setpoint.a_ff_N_mps2.norm());
      if (out.setpoint.a_ff_N_mps2.dot(out.setpoint.v_ff_N_mps) < 0.0) ++braking_ticks;
    }
    FollowExactly(out, &s);
    s.t_s += dt;
  }
  ASSERT_TRUE(seq.done());
  EXPECT_GT(braking_ticks, 1000);  // the square brakes at every corner and at the top of the climb
  EXPECT_LE(max_a, params.accel_mps2 * (1.0 + 1e-6)) << braking_ticks;
}

TEST(SequencerTest, GivenSquare_ThenPlannedPathHasTakeoffCornersAndLanding) {
  const Mission m = LoadShipped("square");
  const std::vector<Vector3d> path = PlannedPath(m, Vector3d::Zero());
  ASSERT_EQ(path.size(), 7u);
  EXPECT_EQ(path[1], Vector3d(0, 0, -10));
  EXPECT_EQ(path[3], Vector3d(40, 40, -10));
  EXPECT_EQ(path[6], Vector3d(0, 0, 0));
  // Cross-track: 3 m beside the middle of leg 2 (corner 1 → corner 2).
  EXPECT_NEAR(CrossTrackToLeg(path, 2, Vector3d(43, 20, -10)), 3.0, 1e-12);
  EXPECT_NEAR(CrossTrack(path, Vector3d(43, 20, -10)), 3.0, 1e-12);
  // Past a segment's end the distance is to its end point.
  EXPECT_NEAR(CrossTrackToLeg(path, 2, Vector3d(40, 44, -7)), 5.0, 1e-12);
}

struct FlightResult {
  bool done = false;
  bool landed = false;
  double time_s = 0.0;
  double max_cross_track_m = 0.0;
  int arrivals = 0;
  int payload_events = 0;
  double max_alt_dev_after_event_m = 0.0;
};

FlightResult Fly(const Mission& m) {
  testing::PlantParams pp;
  testing::RigidBodyPlant plant(pp, *Mixer::Create(testing::HexLayout()));
  plant.set_mass_kg(pp.mass_kg + m.payload_kg);
  CascadedController controller(ControllerParams(), VehicleModelForControl{pp.mass_kg, pp.inertia_kgm2,
                                                                          6 * plant.max_rotor_thrust_N()});
  MissionSequencer seq(m);
  const std::vector<Vector3d> path = PlannedPath(m, plant.state().p_N_m);
  FlightResult r;
  const double dt = 0.002;
  double event_t = -1.0, event_D = 0.0;
  for (int i = 0; i < 150 / dt && !seq.done(); ++i) {
    const SequencerOutput out = seq.Step(plant.state(), dt);
    if (out.payload_event) {
      ++r.payload_events;
      const double sign = out.payload_event->action == PayloadAction::kAttach ? 1.0 : -1.0;
      plant.set_mass_kg(plant.mass_kg() + sign * out.payload_event->mass_kg);
      event_t = plant.state().t_s;
      event_D = out.setpoint.p_N_m.z();
    }
    if (out.arrival) ++r.arrivals;
    if (event_t >= 0.0 && plant.state().t_s < event_t + 2.0) {
      r.max_alt_dev_after_event_m = std::max(r.max_alt_dev_after_event_m, std::abs(plant.state().p_N_m.z() - event_D));
    }
    plant.Step(controller.Update(plant.state(), out.setpoint, dt), dt);
    if (seq.mode() == FlightMode::kWaypoint) {
      const double ct = CrossTrackToLeg(path, seq.active_leg(), plant.state().p_N_m);
      r.max_cross_track_m = std::max(r.max_cross_track_m, ct);
    }
  }
  r.done = seq.done();
  r.landed = seq.landed();
  r.time_s = plant.state().t_s;
  return r;
}

// Peak altitude deviation of the idealised vertical loop (position P → velocity PI → thrust computed
// for a model mass m) when the true mass steps from M0 to M1 while hovering:
//   ḧ = (m/M)·(g + a_cmd) − g,  a_cmd = kv·e + I,  e = kp·(0 − h) − ḣ,  İ = ki·e (limited).
double LinearMassStepPeak(double m_model, double M0, double M1) {
  const ControllerParams p;
  const double g = kGravity_mps2;
  // Trim before the step: I such that (m/M0)(g + I) = g.
  double I = std::clamp(g * M0 / m_model - g, -p.vel_z.integrator_limit, p.vel_z.integrator_limit);
  double h = 0.0, v = 0.0, peak = 0.0;
  const double dt = 1e-3;
  for (double t = 0.0; t < 10.0; t += dt) {
    const double e = p.pos_z_kp * (-h) - v;
    I = std::clamp(I + p.vel_z.ki * e * dt, -p.vel_z.integrator_limit, p.vel_z.integrator_limit);
    const double a_cmd = std::clamp(p.vel_z.kp * e + I, -p.vel_z.output_limit, p.vel_z.output_limit);
    v += ((m_model / M1) * (g + a_cmd) - g) * dt;
    h += v * dt;
    peak = std::max(peak, std::abs(h));
  }
  return peak;
}

// GIVEN an altitude estimate 2 m below the truth (a baro offset from the ground at take-off; 1.8 m
// in a windy run that never landed) and a horizontal velocity estimate that gusts keep jittering by
// 0.3 m/s, WHEN the square is flown and landed, THEN it touches down and the sequencer declares it
// landed within 60 s of its last waypoint. The descent used to stop 1 m below the ground it believed
// in, 1 m above the real one, and hover there until the 900 s cap: "still" never held in the gusts.
TEST(SequencerTest, GivenAnAltitudeEstimateTwoMetresLowAndGustyVelocity_WhenLanding_ThenItStillTouchesDown) {
  const Mission m = LoadShipped("square");
  testing::PlantParams pp;
  testing::RigidBodyPlant plant(pp, *Mixer::Create(testing::HexLayout()));
  CascadedController controller(ControllerParams(), VehicleModelForControl{pp.mass_kg, pp.inertia_kgm2,
                                                                          6 * plant.max_rotor_thrust_N()});
  MissionSequencer seq(m);
  const double dt = 0.002, offset_D_m = 2.0, jitter_mps = 0.3;
  const double weight_N = pp.mass_kg * kGravity_mps2;
  double collective_to_weight = 0.0, last_arrival_s = -1.0;
  auto landed_after_flight = [&] { return last_arrival_s > 0.0 && seq.landed(); };
  for (int i = 0; i < 300 / dt && !landed_after_flight(); ++i) {
    NavState est = plant.state();
    est.p_N_m.z() += offset_D_m;
    est.v_N_mps.x() += (i / 250) % 2 == 0 ? jitter_mps : -jitter_mps;  // flips every 0.5 s
    const SequencerOutput out = seq.Step(est, dt, true, collective_to_weight);
    if (out.arrival) last_arrival_s = plant.state().t_s;
    const ControlOutput u = controller.Update(est, out.setpoint, dt);
    collective_to_weight = u.thrust_N / weight_N;
    plant.Step(u, dt);
  }
  ASSERT_GT(last_arrival_s, 0.0);
  ASSERT_TRUE(landed_after_flight()) << "still flying at true height " << -plant.state().p_N_m.z() << " m";
  EXPECT_TRUE(plant.on_ground());
  EXPECT_LT(plant.state().t_s - last_arrival_s, 60.0);
}

class ShippedMissionTest : public ::testing::TestWithParam<std::string> {};

TEST_P(ShippedMissionTest, GivenShippedMission_WhenFlownClosedLoop_ThenItCompletesOnTrackWithinTwoMinutes) {
  const Mission m = LoadShipped(GetParam());
  const FlightResult r = Fly(m);
  EXPECT_TRUE(r.done);
  EXPECT_TRUE(r.landed);
  EXPECT_LT(r.time_s, 120.0);
  EXPECT_EQ(r.arrivals, CountWaypoints(m));
  int payload_items = 0;
  for (const MissionItem& it : m.items) payload_items += it.type == MissionItemType::kPayload;
  EXPECT_EQ(r.payload_events, payload_items);
  // The carrot leads the vehicle along the segment with velocity and acceleration feed-forward, so
  // what is left is the velocity loop's lag: 0.5 m. A payload the controller does not know about
  // sags (or lifts) the vehicle before the altitude integrator takes it up: bounded by the linear
  // vertical loop's response to that mass step (1.3× plus 10 cm for the lags it leaves out).
  double sag_bound_m = 0.0;
  double mass_kg = testing::PlantParams().mass_kg + m.payload_kg;
  for (const MissionItem& it : m.items) {
    if (it.type != MissionItemType::kPayload) continue;
    const double after = mass_kg + (it.action == PayloadAction::kAttach ? it.mass_kg : -it.mass_kg);
    sag_bound_m = std::max(sag_bound_m, 1.3 * LinearMassStepPeak(testing::PlantParams().mass_kg, mass_kg, after) + 0.1);
    mass_kg = after;
  }
  EXPECT_LT(r.max_alt_dev_after_event_m, std::max(sag_bound_m, 1e-9));
  EXPECT_LT(r.max_cross_track_m, 0.5 + sag_bound_m) << GetParam();
  std::cout << GetParam() << ": " << r.time_s << " s, max cross-track " << r.max_cross_track_m
            << " m, altitude deviation after payload events " << r.max_alt_dev_after_event_m << " m\n";
}

INSTANTIATE_TEST_SUITE_P(Missions, ShippedMissionTest,
                         ::testing::Values("square", "payload_change", "climb_cruise_square", "figure_eight",
                                           "lawnmower", "payload_pickup_drop"));

}  // namespace
}  // namespace hexsim::control
