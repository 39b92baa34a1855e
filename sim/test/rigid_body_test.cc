// Physics laws of the ODE rigid body, checked against closed-form answers.
#include "hexsim/sim/rigid_body.h"

#include <gtest/gtest.h>

namespace hexsim::sim {
namespace {

constexpr double kG = 9.80665;

RigidBodyParams Hex() {
  RigidBodyParams p;
  p.mass_kg = 2.0;
  p.inertia_kgm2 << 0.03, 0.001, 0.0, 0.001, 0.035, 0.0, 0.0, 0.0, 0.06;
  return p;
}

TEST(RigidBody, GivenNoForcesWhenReleasedThenFallsAsHalfGTSquared) {
  BodyState s0;
  s0.p_N_m = {0, 0, -100};
  RigidBodyWorld w(Hex(), s0, /*ground=*/false);
  const double dt = 0.001;
  for (int i = 0; i < 2000; ++i) w.Step(dt);
  const double t = 2.0;
  // Semi-implicit Euler: D error is g·dt·t/2 = 0.0098 m at t = 2 s.
  EXPECT_NEAR(w.State().p_N_m.z(), -100 + 0.5 * kG * t * t, kG * dt * t);
  EXPECT_NEAR(w.State().v_N_mps.z(), kG * t, 1e-9);
}

TEST(RigidBody, GivenThrustEqualToWeightWhenHoveringThenStaysPut) {
  BodyState s0;
  s0.p_N_m = {1, 2, -10};
  RigidBodyWorld w(Hex(), s0, false);
  for (int i = 0; i < 5000; ++i) {
    w.AddForce_B({0, 0, -2.0 * kG});
    w.Step(0.001);
  }
  EXPECT_LT((w.State().p_N_m - s0.p_N_m).norm(), 1e-9);
}

TEST(RigidBody, GivenTorqueFreeSpinThenAngularMomentumIsConserved) {
  BodyState s0;
  s0.w_B_radps = {3.0, -2.0, 5.0};
  const RigidBodyParams p = Hex();
  RigidBodyWorld w(p, s0, false);
  auto momentum_N = [&](const BodyState& s) { return (s.q_NB * (p.inertia_kgm2 * s.w_B_radps)).eval(); };
  const Eigen::Vector3d L0 = momentum_N(w.State());
  const double E0 = 0.5 * s0.w_B_radps.dot(p.inertia_kgm2 * s0.w_B_radps);
  for (int i = 0; i < 3000; ++i) w.Step(0.001);
  const BodyState s = w.State();
  // Second-order gyroscopic torque: local error O((|w|·dt)³) per step, (6e-3)³·3000 ≈ 7e-4 here.
  EXPECT_LT((momentum_N(s) - L0).norm() / L0.norm(), 2e-3);
  EXPECT_NEAR(0.5 * s.w_B_radps.dot(p.inertia_kgm2 * s.w_B_radps), E0, 5e-4 * E0);
}

TEST(RigidBody, GivenBodyResitingOnGroundThenItDoesNotDrift) {
  BodyState s0;
  s0.p_N_m = {0, 0, -0.5};
  RigidBodyParams p = Hex();
  RigidBodyWorld w(p, s0, true);
  for (int i = 0; i < 3000; ++i) w.Step(0.001);  // falls and settles
  const BodyState settled = w.State();
  EXPECT_GT(w.contact_count(), 0);
  for (int i = 0; i < 10000; ++i) w.Step(0.001);
  const BodyState s = w.State();
  EXPECT_LT((s.p_N_m - settled.p_N_m).norm(), 1e-3);
  EXPECT_LT(s.v_N_mps.norm(), 1e-3);
  // Gear bottom at the ground: CG sits gear_offset + half the gear height above it.
  EXPECT_NEAR(s.p_N_m.z(), -(p.gear_offset_B_m.z() + 0.5 * p.gear_size_m.z()), 0.01);
}

}  // namespace
}  // namespace hexsim::sim
