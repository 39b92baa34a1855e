#include "hexsim/vehicle/sensors.h"

#include <cmath>
#include <string>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "hexsim/common/rotation.h"
#include "hexsim/magnetics/current_field.h"

namespace hexsim::vehicle {
namespace {

constexpr double kDt_s = 1e-3;
// A 100 m wire seen from 0.1 m: the infinite-wire field times 50/sqrt(50^2 + 0.1^2).
const double kFiniteWire = 50.0 / std::sqrt(50.0 * 50.0 + 0.1 * 0.1);

// A two-rotor vehicle with clean sensors; tests switch on what they look at.
VehicleParams Quiet() {
  VehicleParams p;
  p.name = "test";
  p.mass_kg = 1.0;
  p.rotors.resize(2);
  p.sensors.gyro = {400.0, {}};
  p.sensors.accel = {400.0, {}};
  p.sensors.gps = GpsParams{};
  p.sensors.gps.latency_s = 0.2;
  p.sensors.baro = BaroParams{};
  CompassParams c;
  c.name = "mag";
  c.rate_hz = 50.0;
  p.compasses.push_back(c);
  return p;
}

SensorTruth Truth(double t_s) {
  SensorTruth t;
  t.t_s = t_s;
  t.specific_force_B_mps2 = Eigen::Vector3d(0.0, 0.0, -kGravity_mps2);
  t.B_earth_N_uT = Eigen::Vector3d(27.0, -3.0, 47.0);
  t.currents.motor_A.assign(2, 0.0);
  return t;
}

SensorSuite Make(const VehicleParams& p, uint64_t seed) {
  Result<SensorSuite> s = SensorSuite::Create(p, seed);
  HEXSIM_CHECK(s.ok());
  return std::move(s).value();
}

TEST(Sensors, GivenGyroWhiteNoiseWhenSampledManyTimesThenMeanAndStdMatchConfigWithinSamplingError) {
  VehicleParams p = Quiet();
  const double sigma = 0.01;
  p.sensors.gyro.noise.noise_std = sigma;
  SensorSuite s = Make(p, 3);
  const Eigen::Vector3d w_true(0.1, -0.2, 0.3);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum2 = Eigen::Vector3d::Zero();
  int n = 0;
  for (int k = 0; k < 50000; ++k) {
    SensorTruth t = Truth(k * kDt_s);
    t.w_B_radps = w_true;
    const SensorReadings& r = s.Step(t);
    if (!r.gyro_radps.fresh) continue;
    const Eigen::Vector3d e = r.gyro_radps.value - w_true;
    sum += e;
    sum2 += e.cwiseProduct(e);
    ++n;
  }
  ASSERT_EQ(n, 20000);
  for (int i = 0; i < 3; ++i) {
    const double mean = sum(i) / n;
    const double std = std::sqrt(sum2(i) / n - mean * mean);
    EXPECT_NEAR(mean, 0.0, 4.0 * sigma / std::sqrt(n));                // 4 standard errors
    EXPECT_NEAR(std, sigma, 4.0 * sigma / std::sqrt(2.0 * n));         // std of a sample std
  }
}

TEST(Sensors, GivenConstantBiasStdWhenManySeedsThenBiasesSpreadAsConfiguredAndStayConstant) {
  VehicleParams p = Quiet();
  const double bias_std = 0.05;
  p.sensors.accel.noise.bias_std = bias_std;
  const int seeds = 800;
  double sum2 = 0.0;
  for (int seed = 0; seed < seeds; ++seed) {
    SensorSuite s = Make(p, static_cast<uint64_t>(seed));
    const Eigen::Vector3d first = s.Step(Truth(0.0)).accel_mps2.value - Truth(0.0).specific_force_B_mps2;
    for (int k = 1; k < 20; ++k) s.Step(Truth(k * kDt_s));
    const Eigen::Vector3d later = s.readings().accel_mps2.value - Truth(0.0).specific_force_B_mps2;
    EXPECT_NEAR((later - first).norm(), 0.0, 1e-12);  // no walk, no noise: a constant offset
    sum2 += first.squaredNorm();
  }
  const double std = std::sqrt(sum2 / (3.0 * seeds));
  EXPECT_NEAR(std, bias_std, 4.0 * bias_std / std::sqrt(2.0 * 3.0 * seeds));
}

TEST(Sensors, GivenBiasRandomWalkWhenRunForTimeTThenBiasVarianceGrowsAsWalkSquaredTimesT) {
  VehicleParams p = Quiet();
  const double walk = 0.01;  // per sqrt(s)
  p.sensors.gyro.noise.bias_walk_per_sqrt_s = walk;
  p.sensors.gyro.rate_hz = 100.0;
  const int seeds = 400;
  const double T_s = 2.0;
  double sum2 = 0.0;
  for (int seed = 0; seed < seeds; ++seed) {
    SensorSuite s = Make(p, static_cast<uint64_t>(seed));
    for (int k = 0; k <= static_cast<int>(std::lround(T_s / kDt_s)); ++k) s.Step(Truth(k * kDt_s));
    sum2 += s.gyro_bias_radps().squaredNorm();
  }
  const double var = sum2 / (3.0 * seeds);
  const double expected = walk * walk * T_s;
  EXPECT_NEAR(var, expected, 4.0 * expected * std::sqrt(2.0 / (3.0 * seeds)));
}

TEST(Sensors, GivenConfiguredRatesWhenRunTenSecondsThenEachSensorSamplesAtItsRate) {
  VehicleParams p = Quiet();
  p.sensors.baro.rate_hz = 50.0;
  p.sensors.gps.rate_hz = 5.0;
  p.compasses[0].rate_hz = 75.0;
  SensorSuite s = Make(p, 1);
  int gyro = 0, mag = 0, gps = 0, baro = 0;
  double last_mag_t = -1.0, max_mag_gap = 0.0;
  const int steps = 10000;
  for (int k = 0; k < steps; ++k) {
    const SensorReadings& r = s.Step(Truth(k * kDt_s));
    gyro += r.gyro_radps.fresh;
    gps += r.gps.fresh;
    baro += r.baro.fresh;
    if (r.mag_uT[0].fresh) {
      ++mag;
      if (last_mag_t >= 0.0) max_mag_gap = std::max(max_mag_gap, r.mag_uT[0].t_s - last_mag_t);
      last_mag_t = r.mag_uT[0].t_s;
      EXPECT_DOUBLE_EQ(r.mag_uT[0].t_s, k * kDt_s);
    }
  }
  const double T_s = steps * kDt_s;
  EXPECT_NEAR(gyro, 400.0 * T_s, 1.0);
  EXPECT_NEAR(mag, 75.0 * T_s, 1.0);
  EXPECT_NEAR(baro, 50.0 * T_s, 1.0);
  EXPECT_NEAR(gps, 5.0 * (T_s - 0.2), 1.0);  // the first fix needs latency_s of history
  EXPECT_LE(max_mag_gap, 1.0 / 75.0 + kDt_s + 1e-12);  // never more than one physics step late
}

TEST(Sensors, GivenGpsLatencyWhenVehicleMovesThenFixReportsPositionFromLatencyAgo) {
  VehicleParams p = Quiet();
  p.sensors.gps.latency_s = 0.25;
  SensorSuite s = Make(p, 1);
  const Eigen::Vector3d v(3.0, -1.0, 0.5);
  int fixes = 0;
  for (int k = 0; k < 3000; ++k) {
    SensorTruth t = Truth(k * kDt_s);
    t.p_N_m = v * t.t_s + Eigen::Vector3d(0.0, 0.0, -0.5 * t.t_s * t.t_s);
    t.v_N_mps = v + Eigen::Vector3d(0.0, 0.0, -t.t_s);
    const SensorReadings& r = s.Step(t);
    if (!r.gps.fresh) continue;
    ++fixes;
    const double epoch = t.t_s - 0.25;
    EXPECT_NEAR(r.gps.t_s, epoch, 1e-12);
    EXPECT_NEAR(r.gps.available_t_s, t.t_s, 1e-12);
    // Linear interpolation between 1 ms samples of a quadratic: error <= a*dt^2/8.
    EXPECT_LT((r.gps.p_N_m - (v * epoch + Eigen::Vector3d(0, 0, -0.5 * epoch * epoch))).norm(), 1e-6);
    EXPECT_LT((r.gps.v_N_mps - (v + Eigen::Vector3d(0, 0, -epoch))).norm(), 1e-9);
  }
  EXPECT_GT(fixes, 10);
}

TEST(Sensors, GivenSameSeedWhenRunTwiceThenIdenticalAndDifferentSeedDiffers) {
  VehicleParams p = Quiet();
  p.sensors.gyro.noise = {0.01, 0.01, 0.001};
  p.compasses[0].noise.noise_std = 0.3;
  p.sensors.baro.noise_m.noise_std = 0.5;
  auto run = [&](uint64_t seed) {
    SensorSuite s = Make(p, seed);
    std::vector<double> out;
    for (int k = 0; k < 500; ++k) {
      const SensorReadings& r = s.Step(Truth(k * kDt_s));
      out.push_back(r.gyro_radps.value.x());
      out.push_back(r.mag_uT[0].value.y());
      out.push_back(r.baro.alt_m);
    }
    return out;
  };
  EXPECT_EQ(run(42), run(42));
  EXPECT_NE(run(42), run(43));
}

TEST(Sensors, GivenAddingACompassWhenSameSeedThenGyroNoiseIsUnchanged) {
  VehicleParams p = Quiet();
  p.sensors.gyro.noise.noise_std = 0.01;
  VehicleParams q = p;
  q.compasses.push_back(q.compasses[0]);
  q.compasses[1].name = "mag2";
  SensorSuite a = Make(p, 9), b = Make(q, 9);
  for (int k = 0; k < 100; ++k) {
    EXPECT_EQ(a.Step(Truth(k * kDt_s)).gyro_radps.value, b.Step(Truth(k * kDt_s)).gyro_radps.value);
  }
}

TEST(Sensors, GivenCompassWithoutNoiseOrCurrentsWhenSampledThenReadsSoftIronTimesEarthInBodyPlusHardIron) {
  VehicleParams p = Quiet();
  p.compasses[0].error.soft_iron << 1.04, 0.03, 0.02, 0.03, 0.97, -0.01, 0.02, -0.01, 1.01;
  p.compasses[0].error.hard_iron_uT = Eigen::Vector3d(5.0, -3.5, 12.0);
  SensorSuite s = Make(p, 5);
  SensorTruth t = Truth(0.0);
  t.q_NB = QuatFromEuler(0.2, -0.1, 2.0);
  const Eigen::Vector3d expected =
      p.compasses[0].error.soft_iron * (t.q_NB.toRotationMatrix().transpose() * t.B_earth_N_uT) +
      p.compasses[0].error.hard_iron_uT;
  EXPECT_LT((s.Step(t).mag_uT[0].value - expected).norm(), 1e-10);
}

TEST(Sensors, GivenLongWireBesideCompassWhenCurrentFlowsThenReadingShiftsByInfiniteWireField) {
  VehicleParams p = Quiet();
  magnetics::WireSegment wire;  // a 100 m wire along +x through the origin
  wire.a_B_m = Eigen::Vector3d(-50.0, 0.0, 0.0);
  wire.b_B_m = Eigen::Vector3d(50.0, 0.0, 0.0);
  wire.source = magnetics::CurrentSource::kBattery;
  p.wiring.segments.push_back(wire);
  p.compasses[0].position_B_m = Eigen::Vector3d(0.0, 0.1, 0.0);
  SensorSuite s = Make(p, 5);
  SensorTruth off = Truth(0.0), on = Truth(1.0);
  on.currents.battery_A = 20.0;
  const Eigen::Vector3d delta = s.Step(on).mag_uT[0].value - Make(p, 5).Step(off).mag_uT[0].value;
  // |B| = mu0*I/(2*pi*d) = 0.2 uT*m/A * 20 A / 0.1 m = 40 uT, along +z for current +x, point +y;
  // the finite 100 m length scales it by cos(theta) = 50/sqrt(50^2 + 0.1^2).
  EXPECT_NEAR(delta.z(), 40.0 * kFiniteWire, 40.0 * 1e-9);
  EXPECT_NEAR(delta.head<2>().norm(), 0.0, 1e-9);
}

TEST(Sensors, GivenCompassCurrentLagWhenCurrentStepsThenFieldReachesOneMinusOneOverEAfterTau) {
  VehicleParams p = Quiet();
  magnetics::WireSegment wire;
  wire.a_B_m = Eigen::Vector3d(-50.0, 0.0, 0.0);
  wire.b_B_m = Eigen::Vector3d(50.0, 0.0, 0.0);
  p.wiring.segments.push_back(wire);
  p.compasses[0].position_B_m = Eigen::Vector3d(0.0, 0.1, 0.0);
  p.compasses[0].current_lag_tau_s = 0.1;
  p.compasses[0].rate_hz = 1000.0;
  SensorSuite s = Make(p, 5);
  const double base_z = s.Step(Truth(0.0)).mag_uT[0].value.z();
  double z_at_tau = 0.0;
  for (int k = 1; k <= 100; ++k) {
    SensorTruth t = Truth(k * kDt_s);
    t.currents.battery_A = 20.0;
    z_at_tau = s.Step(t).mag_uT[0].value.z() - base_z;
  }
  EXPECT_NEAR(z_at_tau, 40.0 * kFiniteWire * (1.0 - std::exp(-1.0)), 40.0 * 1e-9);
}

TEST(Sensors, GivenBaroWhenVehicleClimbsThenAltitudeIsMinusDown) {
  VehicleParams p = Quiet();
  SensorSuite s = Make(p, 1);
  SensorTruth t = Truth(0.0);
  t.p_N_m = Eigen::Vector3d(1.0, 2.0, -12.5);
  EXPECT_DOUBLE_EQ(s.Step(t).baro.alt_m, 12.5);
}

}  // namespace
}  // namespace hexsim::vehicle
