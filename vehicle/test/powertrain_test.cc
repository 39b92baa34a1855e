#include "hexsim/vehicle/powertrain.h"

#include <cmath>
#include <string>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "support/shipped_vehicle.h"

#include "hexsim/common/rng.h"
#include "hexsim/common/rotation.h"
#include "hexsim/vehicle/vehicle_io.h"

namespace hexsim::vehicle {
namespace {

VehicleParams Load(const std::string& name) { return vehicletest::LoadShipped(name); }

constexpr double kDt_s = 1e-3;  // the simulator's physics step

TEST(Powertrain, GivenManyOperatingPointsWhenEvaluatedThenElectricalPowerBalancesToRoundOff) {
  const VehicleParams p = Load("paper_hex");
  RngStream rng(7, "operating_points");
  int driven = 0;
  for (int trial = 0; trial < 500; ++trial) {
    PowertrainState s = InitialPowertrainState(p);
    s.soc = rng.Uniform();
    std::vector<double> cmd(p.rotors.size());
    for (size_t i = 0; i < cmd.size(); ++i) {
      cmd[i] = rng.Uniform() < 0.1 ? 0.0 : rng.Uniform();
      s.omega_radps[i] = 700.0 * rng.Uniform();
    }
    const PowertrainOutput out = EvaluatePowertrain(p, s, cmd);
    for (const MotorOperatingPoint& m : out.motors) {
      // V_bus*I_dc = E*(I_w - I_0) + I_w^2*R + E*I_0 + (1 - eta)*V_bus*I_dc
      const double rhs = m.shaft_W + m.copper_W + m.no_load_W + m.esc_loss_W;
      EXPECT_NEAR(m.power_in_W, rhs, 1e-9 * std::max(1.0, m.power_in_W));
      EXPECT_NEAR(m.motor_V, m.winding_A > 0.0 ? m.back_emf_V + m.winding_A * p.motor.winding_resistance_ohm : m.motor_V,
                  1e-9 * std::max(1.0, m.motor_V));
      EXPECT_GE(m.dc_A, 0.0);
      driven += m.winding_A > 0.0 ? 1 : 0;
    }
    // Battery: V_bus = V_oc - R_int*I_batt, I_batt = sum I_dc + avionics.
    double sum_dc = 0.0;
    for (const MotorOperatingPoint& m : out.motors) sum_dc += m.dc_A;
    EXPECT_NEAR(out.battery_A, sum_dc + p.avionics_current_A, 1e-9 * out.battery_A);
    EXPECT_NEAR(out.bus_V, out.open_circuit_V - p.battery.internal_resistance_ohm * out.battery_A, 1e-9 * out.bus_V);
  }
  EXPECT_GT(driven, 500);  // the sample covered driven motors, not only coasting ones
}

TEST(Powertrain, GivenARunWithThrottleChangesWhenIntegratedThenBatteryEnergyMatchesLossesPlusRotorEnergy) {
  const VehicleParams p = Load("default_hex");
  PowertrainState s = InitialPowertrainState(p);
  s.soc = 0.8;
  const double capacity_As = p.battery.capacity_Ah * 3600.0;
  double chemical_J = 0.0, losses_J = 0.0, aero_J = 0.0, avionics_J = 0.0;
  const int steps = 4000;
  for (int k = 0; k < steps; ++k) {
    const double t = k * kDt_s;
    const double c = t < 1.0 ? 0.5 : (t < 2.0 ? 0.8 : (t < 3.0 ? 0.3 : 0.6));
    const double soc_before = s.soc;
    const PowertrainOutput out = StepPowertrain(p, std::vector<double>(p.rotors.size(), c), kDt_s, &s);
    chemical_J += out.open_circuit_V * (soc_before - s.soc) * capacity_As;  // ∫ V_oc dQ
    losses_J += out.battery_loss_W * kDt_s;
    avionics_J += out.bus_V * p.avionics_current_A * kDt_s;
    for (const MotorOperatingPoint& m : out.motors) {
      losses_J += (m.copper_W + m.no_load_W + m.esc_loss_W) * kDt_s;
      aero_J += m.aero_W * kDt_s;
    }
  }
  double kinetic_J = 0.0;
  for (size_t i = 0; i < p.rotors.size(); ++i) kinetic_J += 0.5 * p.RotorInertia_kgm2(i) * std::pow(s.omega_radps[i], 2);
  // Drawn energy = battery + motor/ESC losses + avionics + work done on the air + spin energy. The
  // explicit evaluation of the torque at the step's start makes the split first order in dt: the
  // mismatch is bounded by the rotor energy changes times dt/tau (~1e-3/0.02), far below 1 %.
  const double balance_J = losses_J + avionics_J + aero_J + kinetic_J;
  EXPECT_NEAR(chemical_J, balance_J, 0.005 * chemical_J);
  EXPECT_GT(kinetic_J, 0.0);
}

TEST(Powertrain, GivenPaperHexClampedWhenControlAmountRisesThenBatteryCurrentRisesMonotonicallyUntilTheEscLimit) {
  const VehicleParams p = Load("paper_hex");
  double previous_A = -1.0;
  int limited = 0;
  for (int u = 0; u <= 1000; u += 50) {
    const PowertrainOutput out = SteadyStateForCommand(p, u / 1000.0, p.battery.initial_soc);
    if (out.esc_limited == 0) {
      EXPECT_GT(out.battery_A, previous_A) << "u=" << u;
    } else {  // every ESC at its limit: the battery current holds at 6 L + avionics
      ++limited;
      EXPECT_NEAR(out.battery_A, 6.0 * p.esc.current_limit_A + p.avionics_current_A, 1e-6) << "u=" << u;
    }
    previous_A = out.battery_A;
  }
  EXPECT_GT(limited, 0);  // full command is beyond the 30 A the ESCs allow
}

TEST(Powertrain, GivenPaperHexClampedWhenAtPaperControlAmountsThenCurrentsMatchTable1Within10Percent) {
  const VehicleParams p = Load("paper_hex");
  const double soc = p.battery.initial_soc;
  EXPECT_NEAR(SteadyStateForCommand(p, 0.0, soc).battery_A, p.avionics_current_A, 1e-12);
  EXPECT_NEAR(SteadyStateForCommand(p, 0.2, soc).battery_A, 32.0, 3.2);
  EXPECT_NEAR(SteadyStateForCommand(p, 0.3, soc).battery_A, 53.0, 5.3);
}

TEST(Powertrain, GivenEachShippedVehicleWhenAtFullCommandThenThrustExceeds1point8TimesWeight) {
  for (const char* name : {"default_hex", "paper_hex", "quad_x", "octo_x"}) {
    const VehicleParams p = Load(name);
    const double weight_N = p.mass_kg * kGravity_mps2;
    const PowertrainOutput full = SteadyStateForCommand(p, 1.0, p.battery.initial_soc);
    EXPECT_GE(full.total_thrust_N, 1.8 * weight_N) << name;
    // And hover is reached well inside the command range at a realistic state of charge.
    const PowertrainOutput half = SteadyStateForCommand(p, 0.6, 0.3);
    EXPECT_GT(half.total_thrust_N, weight_N) << name;
  }
}

TEST(Powertrain, GivenLoadWhenCurrentRisesThenBusVoltageSagsByInternalResistanceTimesCurrent) {
  const VehicleParams p = Load("paper_hex");
  const PowertrainOutput low = SteadyStateForCommand(p, 0.2, 0.5);
  const PowertrainOutput high = SteadyStateForCommand(p, 0.8, 0.5);
  EXPECT_LT(high.bus_V, low.bus_V);
  EXPECT_LT(low.bus_V, low.open_circuit_V);
  EXPECT_NEAR(low.open_circuit_V - high.bus_V - (low.open_circuit_V - low.bus_V),
              p.battery.internal_resistance_ohm * (high.battery_A - low.battery_A), 1e-6);
}

TEST(Powertrain, GivenConstantCommandWhenRunLongThenRotorSpeedSettlesOnTheSteadyStateSolution) {
  const VehicleParams p = Load("quad_x");
  PowertrainState s = InitialPowertrainState(p);
  std::vector<double> cmd = {0.4, 0.5, 0.6, 0.45};
  for (int k = 0; k < 3000; ++k) StepPowertrain(p, cmd, kDt_s, &s);
  s.soc = p.battery.initial_soc;  // compare at the same charge (3 s drains ~0.01 %)
  const PowertrainOutput steady = SteadyStateForCommands(p, cmd, s.soc);
  for (size_t i = 0; i < cmd.size(); ++i) {
    EXPECT_NEAR(s.omega_radps[i], steady.motors[i].omega_radps, 2e-3 * steady.motors[i].omega_radps) << i;
  }
}

TEST(Powertrain, GivenASmallCommandStepWhenIntegratedThenTimeConstantMatchesLinearisedPrediction) {
  const VehicleParams p = Load("paper_hex");
  const double soc = p.battery.initial_soc;
  std::vector<double> cmd(p.rotors.size(), 0.35);
  const PowertrainOutput before = SteadyStateForCommands(p, cmd, soc);
  PowertrainState s = InitialPowertrainState(p);
  s.soc = soc;
  for (size_t i = 0; i < cmd.size(); ++i) s.omega_radps[i] = before.motors[i].omega_radps;
  cmd[0] = 0.37;  // one motor steps; the others hold
  const PowertrainOutput after = SteadyStateForCommands(p, cmd, soc);
  const double w0 = before.motors[0].omega_radps, w1 = after.motors[0].omega_radps;
  // tau = J / (K_t^2/R_eff + 2 k_Q w), R_eff = R + d^2 R_int/eta (the bus sags with this motor's own
  // current), linearised at the final speed.
  const double d = after.motors[0].duty;
  const double Kt = p.motor.Kt_Nm_per_A();
  const double R_eff = p.motor.winding_resistance_ohm + d * d * p.battery.internal_resistance_ohm / p.esc.efficiency;
  const double tau_pred =
      p.RotorInertia_kgm2(0) / (Kt * Kt / R_eff + 2.0 * p.rotors[0].k_Q_Nmprps2 * 0.5 * (w0 + w1));
  const double target = w0 + (1.0 - std::exp(-1.0)) * (w1 - w0);
  double t = 0.0, w_prev = w0, tau_measured = -1.0;
  for (int k = 0; k < 2000 && tau_measured < 0.0; ++k) {
    StepPowertrain(p, cmd, kDt_s, &s);
    t += kDt_s;
    if (s.omega_radps[0] >= target) tau_measured = t - kDt_s * (s.omega_radps[0] - target) / (s.omega_radps[0] - w_prev);
    w_prev = s.omega_radps[0];
  }
  ASSERT_GT(tau_measured, 0.0);
  EXPECT_NEAR(tau_measured, tau_pred, 0.05 * tau_pred) << "predicted " << tau_pred;
  EXPECT_GT(tau_pred, 20 * kDt_s);  // a 17" prop is slow: tens of milliseconds
}

TEST(Powertrain, GivenStoppedCommandWhenSpinningThenRotorCoastsDownWithoutDrawingCurrent) {
  const VehicleParams p = Load("default_hex");
  PowertrainState s = InitialPowertrainState(p);
  s.omega_radps.assign(p.rotors.size(), 600.0);
  const std::vector<double> zero(p.rotors.size(), 0.0);
  const PowertrainOutput first = StepPowertrain(p, zero, kDt_s, &s);
  EXPECT_NEAR(first.battery_A, p.avionics_current_A, 1e-12);
  for (int k = 0; k < 5000; ++k) StepPowertrain(p, zero, kDt_s, &s);
  for (double w : s.omega_radps) EXPECT_EQ(w, 0.0);
}

TEST(Powertrain, GivenThrustWhenConvertedToCommandAndBackThenRoundTrips) {
  const VehicleParams p = Load("quad_x");
  const double bus_V = 15.5;
  for (double thrust_N : {2.0, 3.7, 6.0, 9.0}) {
    const double c = CommandForThrust(p, 0, thrust_N, bus_V);
    ASSERT_GT(c, kIdleCommand);
    ASSERT_LT(c, 1.0);
    EXPECT_NEAR(ThrustForCommand(p, 0, c, bus_V), thrust_N, 1e-9 * thrust_N);
  }
  EXPECT_EQ(CommandForThrust(p, 0, 0.0, bus_V), 0.0);
  EXPECT_EQ(CommandForThrust(p, 0, 1e4, bus_V), 1.0);
}

TEST(Powertrain, GivenHexWithEqualRotorSpeedsWhenWrenchComputedThenPureLiftAndNoMoment) {
  const VehicleParams p = Load("default_hex");
  const std::vector<double> omega(p.rotors.size(), 500.0);
  const Wrench w = RotorWrench(p, omega);
  EXPECT_NEAR(w.force_B_N.z(), -6.0 * p.rotors[0].k_T_Nprps2 * 500.0 * 500.0, 1e-9);
  EXPECT_NEAR(w.force_B_N.head<2>().norm(), 0.0, 1e-9);
  EXPECT_NEAR(w.torque_B_Nm.norm(), 0.0, 1e-9);
}

TEST(Powertrain, GivenOnlyCounterClockwiseRotorsFasterWhenWrenchComputedThenBodyYawsNoseRight) {
  const VehicleParams p = Load("quad_x");
  std::vector<double> omega(p.rotors.size(), 500.0);
  for (size_t i = 0; i < p.rotors.size(); ++i) {
    if (p.rotors[i].spin > 0) omega[i] = 550.0;
  }
  const Wrench w = RotorWrench(p, omega);
  // Two CCW rotors: reaction k_Q*(550^2 - 500^2) each about +z (down), i.e. positive yaw.
  EXPECT_NEAR(w.torque_B_Nm.z(), 2.0 * p.rotors[0].k_Q_Nmprps2 * (550.0 * 550.0 - 500.0 * 500.0), 1e-12);
  EXPECT_NEAR(w.torque_B_Nm.head<2>().norm(), 0.0, 1e-9);  // diagonal pair: no roll/pitch
}

TEST(Powertrain, GivenSpinningRotorsAndBodyRollRateWhenWrenchComputedThenGyroscopicTorqueIsMinusWCrossH) {
  VehicleParams p = Load("quad_x");
  std::vector<double> omega(p.rotors.size(), 0.0);
  omega[0] = 800.0;  // one CCW rotor: h = J*800 along -z
  const Eigen::Vector3d w_B(1.0, 0.0, 0.0);
  const Wrench with = RotorWrench(p, omega, w_B);
  const Wrench without = RotorWrench(p, omega);
  const Eigen::Vector3d h = p.RotorInertia_kgm2(0) * 800.0 * Eigen::Vector3d(0, 0, -1);
  EXPECT_TRUE((with.torque_B_Nm - without.torque_B_Nm).isApprox(-w_B.cross(h), 1e-12));
}

}  // namespace
}  // namespace hexsim::vehicle
