// Rotor aerodynamics as a pure function: off by default, ground effect near the ground, rotor drag
// against the air velocity.
#include "hexsim/vehicle/rotor_aero.h"
#include "hexsim/vehicle/vehicle_io.h"

#include <string>

#include <gtest/gtest.h>

namespace hexsim::vehicle {
namespace {

VehicleParams Hex() {
  Result<VehicleParams> v = LoadVehicleFile(std::string(HEXSIM_SOURCE_DIR) + "/worlds/vehicles/default_hex.yaml");
  HEXSIM_CHECK(v.ok());
  return *v;
}

TEST(RotorAero, GivenTheTermsOff_WhenEvaluated_ThenTheWrenchIsZero) {
  const VehicleParams p = Hex();
  EXPECT_FALSE(RotorAeroEnabled(p.aero));
  const Wrench w = RotorAeroWrench(p, std::vector<double>(p.rotors.size(), 600.0), Eigen::Vector3d(5, 2, 0), -0.3,
                                   Eigen::Quaterniond::Identity());
  EXPECT_EQ(w.force_B_N, Eigen::Vector3d::Zero());
  EXPECT_EQ(w.torque_B_Nm, Eigen::Vector3d::Zero());
}

TEST(RotorAero, GivenGroundEffect_WhenLevelNearTheGround_ThenExtraThrustIsUpAndFadesWithHeight) {
  VehicleParams p = Hex();
  p.aero.ground_effect_radius_m = 0.2;
  const std::vector<double> omega(p.rotors.size(), 600.0);
  const Eigen::Quaterniond level = Eigen::Quaterniond::Identity();
  const Wrench low = RotorAeroWrench(p, omega, Eigen::Vector3d::Zero(), -0.3, level);
  const Wrench high = RotorAeroWrench(p, omega, Eigen::Vector3d::Zero(), -5.0, level);
  EXPECT_LT(low.force_B_N.z(), 0.0);  // up (body z is down)
  EXPECT_LT(low.force_B_N.z(), 10.0 * high.force_B_N.z());
  // Symmetric rotors, level: no net moment.
  EXPECT_NEAR(low.torque_B_Nm.norm(), 0.0, 1e-9);
}

TEST(RotorAero, GivenRotorDrag_WhenFlyingForward_ThenTheForceOpposesTheAirVelocityInTheRotorPlane) {
  VehicleParams p = Hex();
  p.aero.rotor_drag_N_per_radps_mps = 5e-5;
  const Wrench w = RotorAeroWrench(p, std::vector<double>(p.rotors.size(), 500.0), Eigen::Vector3d(4, 0, 1), -10,
                                   Eigen::Quaterniond::Identity());
  EXPECT_NEAR(w.force_B_N.x(), -5e-5 * 500.0 * static_cast<double>(p.rotors.size()) * 4.0, 1e-12);
  EXPECT_EQ(w.force_B_N.y(), 0.0);
  EXPECT_EQ(w.force_B_N.z(), 0.0);
}

}  // namespace
}  // namespace hexsim::vehicle
