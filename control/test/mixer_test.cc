#include "hexsim/control/mixer.h"

#include <gtest/gtest.h>

#include "support/plant.h"

namespace hexsim::control {
namespace {

using Eigen::Vector3d;
using Eigen::Vector4d;

Mixer MakeMixer(const std::vector<RotorGeometry>& rotors) {
  Result<Mixer> m = Mixer::Create(rotors);
  EXPECT_TRUE(m.ok()) << m.status().message();
  return *m;
}

void ExpectExactWhenUnsaturated(const Mixer& mixer, double hover_N, double max_N) {
  // Wrenches well inside the attainable set: collective near hover, torques a fraction of the
  // largest a single rotor's thrust margin can give.
  const double arm_torque_Nm = 0.2 * hover_N / mixer.rotor_count();
  const Vector4d cases[] = {{hover_N, 0, 0, 0},
                            {hover_N, arm_torque_Nm * 0.1, 0, 0},
                            {hover_N * 1.2, -arm_torque_Nm * 0.1, arm_torque_Nm * 0.1, 0.02},
                            {hover_N * 0.8, 0.0, -arm_torque_Nm * 0.05, -0.05}};
  for (const Vector4d& w : cases) {
    const MixResult r = mixer.Mix(w(0), w.tail<3>(), max_N);
    EXPECT_FALSE(r.saturated);
    EXPECT_LT((r.achieved - w).norm(), 1e-9 * w.norm()) << w.transpose();
    EXPECT_GE(r.thrust_N.minCoeff(), 0.0);
    EXPECT_LE(r.thrust_N.maxCoeff(), max_N);
  }
}

TEST(MixerTest, GivenHexX_WhenUnsaturated_ThenRequestedWrenchIsReproducedExactly) {
  const Mixer mixer = MakeMixer(testing::HexLayout());
  EXPECT_EQ(mixer.rotor_count(), 6);
  ExpectExactWhenUnsaturated(mixer, 50.0, 20.0);
}

TEST(MixerTest, GivenQuadX_WhenUnsaturated_ThenRequestedWrenchIsReproducedExactly) {
  const Mixer mixer = MakeMixer(testing::QuadLayout());
  EXPECT_EQ(mixer.rotor_count(), 4);
  ExpectExactWhenUnsaturated(mixer, 15.0, 8.0);
}

TEST(MixerTest, GivenFrontRotorsPushHarder_ThenPitchTorqueIsNoseUpAndPseudoInverseIsARightInverse) {
  const auto rotors = testing::HexLayout();
  const Mixer mixer = MakeMixer(rotors);
  Eigen::VectorXd t = Eigen::VectorXd::Constant(6, 5.0);
  for (int i = 0; i < 6; ++i) {
    if (rotors[static_cast<size_t>(i)].p_B_m.x() > 1e-9) t(i) += 1.0;
  }
  const Vector4d w = mixer.allocation() * t;
  EXPECT_NEAR(w(0), 6 * 5.0 + 2.0, 1e-12);  // two front rotors at 30° and 330°
  EXPECT_GT(w(2), 0.0);                      // τy > 0: nose up in FRD
  EXPECT_NEAR(w(1), 0.0, 1e-12);
  EXPECT_LT((mixer.allocation() * mixer.pseudo_inverse() - Eigen::Matrix4d::Identity()).norm(), 1e-12);
}

TEST(MixerTest, GivenCounterClockwiseRotorsPushHarder_ThenBodyYawsClockwise) {
  const auto rotors = testing::HexLayout();
  const Mixer mixer = MakeMixer(rotors);
  Eigen::VectorXd t = Eigen::VectorXd::Constant(6, 5.0);
  for (int i = 0; i < 6; ++i) {
    if (rotors[static_cast<size_t>(i)].spin == 1) t(i) += 1.0;
  }
  const Vector4d w = mixer.allocation() * t;
  // Three CCW rotors each add k_Q/k_T·1 N of reaction torque about +z (down): clockwise from above.
  EXPECT_NEAR(w(3), 3 * rotors[0].torque_to_thrust_m, 1e-12);
}

TEST(MixerTest, GivenYawRequestBeyondMargin_WhenSaturated_ThenRollPitchAndCollectiveKeptAndYawSacrificed) {
  const Mixer mixer = MakeMixer(testing::HexLayout());
  const double max_N = 20.0, hover_N = 6 * 12.0;
  const Vector3d torque(4.0, -3.0, 5.0);  // yaw far beyond k_Q/k_T · margin
  const MixResult r = mixer.Mix(hover_N, torque, max_N);
  EXPECT_TRUE(r.saturated);
  EXPECT_DOUBLE_EQ(r.roll_pitch_scale, 1.0);
  EXPECT_LT(r.yaw_scale, 1.0);
  EXPECT_NEAR(r.achieved(0), hover_N, 1e-9);
  EXPECT_NEAR(r.achieved(1), torque.x(), 1e-9);
  EXPECT_NEAR(r.achieved(2), torque.y(), 1e-9);
  EXPECT_GT(r.achieved(3), 0.0);  // some yaw in the requested direction, never the wrong way
  EXPECT_LT(r.achieved(3), torque.z());
  EXPECT_GE(r.thrust_N.minCoeff(), -1e-12);
  EXPECT_LE(r.thrust_N.maxCoeff(), max_N + 1e-12);
}

TEST(MixerTest, GivenHighCollectiveAndRollTorque_WhenSaturated_ThenCollectiveShiftsToKeepRoll) {
  const Mixer mixer = MakeMixer(testing::HexLayout());
  const double max_N = 20.0;
  const Vector3d torque(10.0, 0.0, 0.0);
  const MixResult r = mixer.Mix(6 * 19.0, torque, max_N);  // near full throttle: no room above
  EXPECT_TRUE(r.saturated);
  EXPECT_NEAR(r.achieved(1), torque.x(), 1e-9);
  EXPECT_LT(r.achieved(0), 6 * 19.0);  // collective gave way
  EXPECT_LE(r.thrust_N.maxCoeff(), max_N + 1e-12);
}

TEST(MixerTest, GivenRollBeyondAnyCollective_WhenSaturated_ThenRollIsScaledAndRotorsStayInBounds) {
  const Mixer mixer = MakeMixer(testing::HexLayout());
  const double max_N = 20.0;
  // Largest roll torque: three rotors on one side at max, the others at 0 → 20·(0.6·(0.5+1+0.5))= 24 N·m.
  const MixResult r = mixer.Mix(60.0, Vector3d(100.0, 0.0, 0.0), max_N);
  EXPECT_TRUE(r.saturated);
  EXPECT_LT(r.roll_pitch_scale, 1.0);
  EXPECT_GT(r.achieved(1), 0.5 * 24.0);
  EXPECT_LE(r.achieved(1), 24.0 + 1e-9);
  EXPECT_GE(r.thrust_N.minCoeff(), 0.0);
  EXPECT_LE(r.thrust_N.maxCoeff(), max_N);
}

TEST(MixerTest, GivenAllRotorsSpinningTheSameWay_WhenCreated_ThenRejectedForMissingYawAuthority) {
  auto rotors = testing::HexLayout();
  for (auto& r : rotors) r.spin = 1;
  const Result<Mixer> m = Mixer::Create(rotors);
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.status().code(), StatusCode::kBadInput);
  EXPECT_FALSE(Mixer::Create(CircularLayout(3, 0.3, 0.0, 1)).ok());
}

TEST(MixerTest, GivenRotorCommands_ThenControlAmountIsMeanTimesThousand) {
  Eigen::VectorXd u(6);
  u << 0.2, 0.3, 0.4, 0.2, 0.3, 0.4;
  EXPECT_DOUBLE_EQ(ControlAmount(u), 300.0);
  EXPECT_DOUBLE_EQ(ControlAmount(Eigen::VectorXd::Zero(4)), 0.0);
  EXPECT_DOUBLE_EQ(ControlAmount(Eigen::VectorXd::Ones(4)), 1000.0);
}

}  // namespace
}  // namespace hexsim::control
