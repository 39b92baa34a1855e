// The shipped vehicles' magnetic set-up against the paper's orders of magnitude.
#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "support/shipped_vehicle.h"

#include "hexsim/common/rotation.h"
#include "hexsim/magnetics/heading.h"
#include "hexsim/magnetics/wmm.h"
#include "hexsim/vehicle/powertrain.h"
#include "hexsim/vehicle/sensors.h"
#include "hexsim/vehicle/vehicle_io.h"

namespace hexsim::vehicle {
namespace {

VehicleParams Load(const std::string& name) { return vehicletest::LoadShipped(name); }

magnetics::EarthField Changchun() {
  Result<magnetics::EarthField> f = magnetics::EvaluateWmm({43.88, 125.35, 200.0}, 2016.5);
  HEXSIM_CHECK(f.ok());
  return *f;
}

// Largest |heading error| over a level 360 deg turn of the noise-free compass, degrees.
double MaxLevelHeadingErrorDeg(const VehicleParams& p, const magnetics::Currents& currents) {
  const magnetics::EarthField field = Changchun();
  double worst = 0.0;
  for (int deg = 0; deg < 360; deg += 2) {
    const double yaw = deg * kPi / 180.0;
    const Eigen::Quaterniond q = QuatFromEuler(0.0, 0.0, yaw);
    const Eigen::Vector3d m = CompassNoiseFree_uT(p.compasses[0], p.wiring, q, field.B_N_uT, currents);
    const double est = magnetics::TrueHeadingRad(m, 0.0, 0.0, field.declination_deg * kPi / 180.0);
    worst = std::max(worst, std::abs(WrapPi(est - yaw)) * 180.0 / kPi);
  }
  return worst;
}

TEST(VehicleMagnetics, GivenPaperHexAt53AWhenFieldAtCompassEvaluatedThenItIsOfOrderPoint12MicroTeslaPerAmp) {
  const VehicleParams p = Load("paper_hex");
  const PowertrainOutput out = SteadyStateForCommand(p, 0.3, p.battery.initial_soc);
  const Eigen::Vector3d dB =
      magnetics::CurrentDrivenField_uT(p.wiring, p.compasses[0].position_B_m, out.Currents());
  const double per_A = dB.norm() / out.battery_A;
  // The brief's order of magnitude: ~0.12 uT/A (a factor 2 either way is the same order).
  EXPECT_GT(per_A, 0.06);
  EXPECT_LT(per_A, 0.24);
  // And it is a heading error of degrees, growing with the control amount.
  const double e0 = MaxLevelHeadingErrorDeg(p, SteadyStateForCommand(p, 0.0, p.battery.initial_soc).Currents());
  const double e300 = MaxLevelHeadingErrorDeg(p, out.Currents());
  EXPECT_GE(e0, 10.0);  // hard + soft iron alone: an uncorrected compass is off by >= 10 deg
  EXPECT_NE(e300, e0);
}

TEST(VehicleMagnetics, GivenQuadXWhenCurrentsFlowThenInternalCompassesSeeMoreFieldPerAmpThanTheExternalOne) {
  const VehicleParams p = Load("quad_x");
  const PowertrainOutput out = SteadyStateForCommand(p, 0.5, p.battery.initial_soc);
  std::vector<double> per_A;
  for (const CompassParams& c : p.compasses) {
    per_A.push_back(magnetics::CurrentDrivenField_uT(p.wiring, c.position_B_m, out.Currents()).norm() / out.battery_A);
  }
  ASSERT_TRUE(p.compasses[0].external);
  EXPECT_LT(per_A[0], 0.1);  // below 1 mG/A on the mast
  for (size_t i = 1; i < per_A.size(); ++i) {
    EXPECT_GT(per_A[i], 3.0 * per_A[0]);
    EXPECT_GT(per_A[i], 0.2);  // real internal compasses: 3-7 mG/A
    EXPECT_LT(per_A[i], 0.8);
  }
}

}  // namespace
}  // namespace hexsim::vehicle
