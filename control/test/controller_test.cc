#include "hexsim/control/control_io.h"
#include "hexsim/control/controller.h"

#include <cmath>

#include <gtest/gtest.h>

#include "hexsim/common/rotation.h"
#include "support/plant.h"

namespace hexsim::control {
namespace {

using Eigen::Quaterniond;
using Eigen::Vector3d;

constexpr double kDt_s = 0.002;  // 500 Hz

struct Loop {
  testing::PlantParams plant_params;
  ControllerParams params;
  testing::RigidBodyPlant plant;
  CascadedController controller;

  explicit Loop(const ControllerParams& p = {}, const testing::PlantParams& pp = {})
      : plant_params(pp),
        params(p),
        plant(pp, *Mixer::Create(testing::HexLayout())),
        controller(p, VehicleModelForControl{pp.mass_kg, pp.inertia_kgm2, 6 * plant.max_rotor_thrust_N()}) {
    plant.state().p_N_m = Vector3d(0, 0, -10);  // airborne, in trim
    plant.TrimForHover();
  }
  void Step(const Setpoint& sp) { plant.Step(controller.Update(plant.state(), sp, kDt_s), kDt_s); }
};

double TiltDeg(const Quaterniond& q) {
  const Vector3d z = q.toRotationMatrix().col(2);
  return std::acos(std::clamp(z.z(), -1.0, 1.0)) * kRadToDeg;
}

TEST(ControllerTest, GivenThirtyDegreeTilt_WhenAttitudeLoopRuns_ThenItLevelsWithinOneSecond) {
  Loop loop;
  loop.plant.state().q_NB = QuatFromEuler(30 * kDegToRad, 0.0, 0.4);
  const double hover_N = loop.plant_params.mass_kg * kGravity_mps2;
  const Quaterniond q_sp = QuatFromEuler(0.0, 0.0, 0.4);
  double max_tilt_after_1s = 0.0;
  for (int i = 0; i < 1500; ++i) {  // 3 s
    const NavState& s = loop.plant.state();
    loop.plant.Step(loop.controller.UpdateAttitude(s, q_sp, hover_N, 0.0, kDt_s), kDt_s);
    if (i * kDt_s > 1.0) max_tilt_after_1s = std::max(max_tilt_after_1s, TiltDeg(loop.plant.state().q_NB));
  }
  // Closed attitude loop ≈ 2nd order with ωn = √(kp_att·kp_rate) ≈ 10.8 rad/s, ζ ≈ 0.88 (plus a 30 ms
  // rotor lag): a 30° error decays below 1° well within 1 s and stays there.
  EXPECT_LT(max_tilt_after_1s, 1.0);
  EXPECT_NEAR(EulerFromQuat(loop.plant.state().q_NB).z(), 0.4, 1e-2);
}

TEST(ControllerTest, GivenTiltAndYawError_WhenAttitudeLoopRuns_ThenTiltIsCorrectedBeforeYaw) {
  Loop loop;
  loop.plant.state().q_NB = QuatFromEuler(0.0, 30 * kDegToRad, 0.0);
  const double hover_N = loop.plant_params.mass_kg * kGravity_mps2;
  const Quaterniond q_sp = QuatFromEuler(0.0, 0.0, 90 * kDegToRad);
  for (int i = 0; i < 150; ++i) {  // 0.3 s
    const NavState& s = loop.plant.state();
    loop.plant.Step(loop.controller.UpdateAttitude(s, q_sp, hover_N, 0.0, kDt_s), kDt_s);
  }
  const double tilt_left = TiltDeg(loop.plant.state().q_NB) / 30.0;
  const double yaw_left =
      std::abs(WrapPi(EulerFromQuat(loop.plant.state().q_NB).z() - 90 * kDegToRad)) / (90 * kDegToRad);
  EXPECT_LT(tilt_left, 0.5 * yaw_left);
}

TEST(ControllerTest, GivenHover_WhenSettled_ThenThrustBalancesWeightAndPositionHolds) {
  Loop loop;
  Setpoint sp;
  sp.p_N_m = Vector3d(0, 0, -10);
  ControlOutput out;
  for (int i = 0; i < 2500; ++i) {
    out = loop.controller.Update(loop.plant.state(), sp, kDt_s);
    loop.plant.Step(out, kDt_s);
  }
  EXPECT_NEAR(out.thrust_N, loop.plant_params.mass_kg * kGravity_mps2, 1e-3 * loop.plant_params.mass_kg * kGravity_mps2);
  EXPECT_LT((loop.plant.state().p_N_m - sp.p_N_m).norm(), 1e-3);
}

// Step response of the idealised horizontal loop: position P (kp) → velocity PI (kv, ki) → a perfect
// acceleration: ẍ = kv·(kp·(r − x) − ẋ) + ki·∫(kp·(r − x) − ẋ). Attitude and rotor lags are left out.
struct LinearStep {
  double max_x = 0.0;
  double final_x = 0.0;
};
LinearStep LinearPositionStep(double kp, double kv, double ki, double r, double t_end_s) {
  double x = 0.0, v = 0.0, i_term = 0.0;
  LinearStep out;
  const double dt = 1e-4;
  for (double t = 0.0; t < t_end_s; t += dt) {
    const double e_v = kp * (r - x) - v;
    i_term += ki * e_v * dt;
    v += (kv * e_v + i_term) * dt;
    x += v * dt;
    out.max_x = std::max(out.max_x, x);
  }
  out.final_x = x;
  return out;
}

TEST(ControllerTest, GivenFiveMetreStep_WhenPositionLoopRuns_ThenOvershootStaysNearTheLinearModels) {
  Loop loop;
  const ControllerParams& p = loop.params;
  const double step_m = 5.0;  // kp·step < max speed: the loop stays linear
  ASSERT_LT(p.pos_xy_kp * step_m, p.max_speed_xy_mps);
  const double t_end_s = 12.0;
  const LinearStep lin = LinearPositionStep(p.pos_xy_kp, p.vel_xy.kp, p.vel_xy.ki, step_m, t_end_s);
  Setpoint sp;
  sp.p_N_m = Vector3d(step_m, 0, -10);
  double max_north = 0.0, max_cross = 0.0, max_alt_err = 0.0;
  for (int i = 0; i < static_cast<int>(t_end_s / kDt_s); ++i) {
    loop.Step(sp);
    const Vector3d& pos = loop.plant.state().p_N_m;
    max_north = std::max(max_north, pos.x());
    max_cross = std::max(max_cross, std::abs(pos.y()));
    max_alt_err = std::max(max_alt_err, std::abs(pos.z() + 10));
  }
  // The attitude loop and rotor lag (tens of ms) and the velocity D term and drag shift the
  // response a little: allow 1.5× the linear model's overshoot plus 5 cm.
  const double lin_overshoot_m = lin.max_x - step_m;
  EXPECT_LT(max_north - step_m, 1.5 * lin_overshoot_m + 0.05) << "linear overshoot " << lin_overshoot_m;
  EXPECT_GT(max_north, step_m - 0.05);
  EXPECT_NEAR(loop.plant.state().p_N_m.x(), lin.final_x, 0.05);
  EXPECT_LT(max_cross, 0.02);
  EXPECT_LT(max_alt_err, 0.2);
}

TEST(ControllerTest, GivenFarWaypoint_WhenFlying_ThenSpeedAndTiltStayWithinLimits) {
  ControllerParams p;
  p.max_speed_xy_mps = 6.0;
  p.max_tilt_deg = 25.0;
  Loop loop(p);
  Setpoint sp;
  sp.p_N_m = Vector3d(60, 60, -10);
  double max_speed = 0.0, max_tilt = 0.0;
  for (int i = 0; i < 7500; ++i) {  // 15 s
    loop.Step(sp);
    max_speed = std::max(max_speed, loop.plant.state().v_N_mps.head<2>().norm());
    max_tilt = std::max(max_tilt, TiltDeg(loop.plant.state().q_NB));
  }
  EXPECT_LT(max_speed, p.max_speed_xy_mps * 1.1);  // the PI velocity loop overshoots by a few %
  EXPECT_GT(max_speed, p.max_speed_xy_mps * 0.95);
  EXPECT_LT(max_tilt, p.max_tilt_deg + 3.0);  // attitude tracking error on top of the setpoint limit
}

TEST(ControllerTest, GivenHeavierVehicleThanModelled_WhenHovering_ThenIntegratorRemovesAltitudeError) {
  testing::PlantParams pp;
  Loop loop(ControllerParams(), pp);
  loop.plant.set_mass_kg(pp.mass_kg * 1.3);  // 30 % payload the controller does not know about
  Setpoint sp;
  sp.p_N_m = Vector3d(0, 0, -10);
  for (int i = 0; i < 7500; ++i) loop.Step(sp);
  EXPECT_NEAR(loop.plant.state().p_N_m.z(), -10.0, 0.02);
}

TEST(ControllerTest, GivenIdleSetpoint_ThenOutputIsZero) {
  Loop loop;
  Setpoint sp;
  sp.idle = true;
  const ControlOutput out = loop.controller.Update(loop.plant.state(), sp, kDt_s);
  EXPECT_EQ(out.thrust_N, 0.0);
  EXPECT_TRUE(out.torque_B_Nm.isZero());
}

TEST(ControllerTest, GivenDesiredThrustVector_ThenAttitudePointsBodyMinusZAlongItWithRequestedYaw) {
  const Vector3d F(3.0, -2.0, -40.0);
  const Quaterniond q = AttitudeFromThrustAndYaw(F, 1.0);
  const Vector3d minus_z = -(q * Vector3d::UnitZ());
  EXPECT_LT((minus_z - F.normalized()).norm(), 1e-12);
  // Heading of the body x axis projected on the horizontal plane.
  const Vector3d x = q * Vector3d::UnitX();
  EXPECT_NEAR(std::atan2(x.y(), x.x()), 1.0, 1e-12);
}

TEST(ControllerParamsTest, GivenSetOverride_WhenParsed_ThenGainChanges) {
  YAML::Node doc;
  doc["control"] = ControllerParamsToYaml(ControllerParams());
  ASSERT_TRUE(ApplyOverride(doc, "control.rate.roll.kp=0.12", "v.yaml").ok());
  ASSERT_TRUE(ApplyOverride(doc, "control.vel.xy.ki=0.7", "v.yaml").ok());
  ControllerParams p;
  YamlReader r(doc["control"], "v.yaml", "control");
  ASSERT_TRUE(ParseControllerParams(r, &p).ok());
  EXPECT_DOUBLE_EQ(p.rate_roll.kp, 0.12);
  EXPECT_DOUBLE_EQ(p.vel_xy.ki, 0.7);
  EXPECT_DOUBLE_EQ(p.rate_pitch.kp, ControllerParams().rate_pitch.kp);  // round trip keeps the rest
  EXPECT_DOUBLE_EQ(p.max_tilt_deg, ControllerParams().max_tilt_deg);
}

TEST(ControllerParamsTest, GivenBadGain_WhenParsed_ThenErrorNamesFileLineAndField) {
  const auto doc = YamlReader::LoadString("control:\n  rate:\n    roll:\n      kp: -1\n", "v.yaml");
  ASSERT_TRUE(doc.ok());
  ControllerParams p;
  YamlReader r((*doc)["control"], "v.yaml", "control");
  const Status s = ParseControllerParams(r, &p);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.message(), "v.yaml:4: control.rate.roll.kp: must be >= 0 (got -1)");
  const auto doc2 = YamlReader::LoadString("control:\n  att:\n    rol: {kp: 1}\n", "v.yaml");
  YamlReader r2((*doc2)["control"], "v.yaml", "control");
  const Status s2 = ParseControllerParams(r2, &p);
  EXPECT_EQ(s2.message(), "v.yaml:3: control.att.rol: unknown key");
}

}  // namespace
}  // namespace hexsim::control
