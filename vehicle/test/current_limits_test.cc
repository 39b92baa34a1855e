// The ESC and battery current limits (powertrain.h): enforced on the duty, to round-off, with the
// electrical power balance intact.
#include <cmath>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "support/shipped_vehicle.h"

#include "hexsim/common/rng.h"
#include "hexsim/vehicle/powertrain.h"
#include "hexsim/vehicle/vehicle_io.h"

namespace hexsim::vehicle {
namespace {

VehicleParams Load(const std::string& name) { return vehicletest::LoadShipped(name); }

constexpr double kDt_s = 1e-3;

TEST(CurrentLimits, GivenAnEscLimitWhenAllRotorsStartFromRestAtFullCommandThenNoEscDrawsMoreThanTheLimit) {
  VehicleParams p = Load("paper_hex");
  p.esc.current_limit_A = 20.0;
  PowertrainState s = InitialPowertrainState(p);
  const std::vector<double> full(p.rotors.size(), 1.0);
  int limited_steps = 0;
  for (int k = 0; k < 3000; ++k) {
    const PowertrainOutput out = StepPowertrain(p, full, kDt_s, &s);
    for (const MotorOperatingPoint& m : out.motors) {
      EXPECT_LE(m.dc_A, 20.0 * (1.0 + 1e-12));
      EXPECT_LE(m.duty, p.esc.Duty(1.0));
      // The ESC at its limit draws exactly the limit: d*(d*V - E)/(eta*R) = L.
      if (m.current_limited) {
        EXPECT_NEAR(m.dc_A, 20.0, 1e-9);
      }
      // Power balance: V_bus*I_dc = shaft + copper + no-load + ESC loss.
      EXPECT_NEAR(m.power_in_W, m.shaft_W + m.copper_W + m.no_load_W + m.esc_loss_W, 1e-9 * m.power_in_W + 1e-12);
    }
    EXPECT_EQ(out.esc_limited, out.motors[0].current_limited ? 6 : 0);
    EXPECT_NEAR(out.bus_V, out.open_circuit_V - p.battery.internal_resistance_ohm * out.battery_A, 1e-9 * out.bus_V);
    limited_steps += out.esc_limited > 0 ? 1 : 0;
  }
  // From rest the winding sees the full duty through R alone (~270 A): limited from the first step,
  // and at 3 s the rotor has settled where the limit allows, still at the limit (full command).
  EXPECT_EQ(limited_steps, 3000);
  const PowertrainOutput steady = SteadyStateForCommand(p, 1.0, s.soc);
  EXPECT_NEAR(s.omega_radps[0], steady.motors[0].omega_radps, 1e-3 * steady.motors[0].omega_radps);
  EXPECT_NEAR(steady.motors[0].dc_A, 20.0, 1e-6);
  EXPECT_EQ(steady.esc_limited, 6);
}

TEST(CurrentLimits, GivenABatteryLimitWhenTheRotorsSpinUpThenTheBatteryCurrentIsHeldAtItAndEveryDutyIsScaledAlike) {
  VehicleParams p = Load("default_hex");
  p.esc.current_limit_A = std::numeric_limits<double>::infinity();
  p.battery.max_current_A = 40.0;
  PowertrainState s = InitialPowertrainState(p);
  const std::vector<double> cmd = {1.0, 0.8, 1.0, 0.8, 1.0, 0.8};
  bool seen = false;
  for (int k = 0; k < 500; ++k) {
    const PowertrainOutput out = StepPowertrain(p, cmd, kDt_s, &s);
    EXPECT_LE(out.battery_A, 40.0 * (1.0 + 1e-9));
    if (!out.battery_limited) continue;
    seen = true;
    EXPECT_NEAR(out.battery_A, 40.0, 1e-6);
    // One common factor k: d_i / d_cmd_i is the same for every ESC.
    const double k0 = out.motors[0].duty / p.esc.Duty(cmd[0]);
    for (size_t i = 0; i < cmd.size(); ++i) EXPECT_NEAR(out.motors[i].duty / p.esc.Duty(cmd[i]), k0, 1e-9);
    EXPECT_LT(k0, 1.0);
  }
  EXPECT_TRUE(seen);
}

TEST(CurrentLimits, GivenRandomOperatingPointsWithBothLimitsWhenEvaluatedThenNeitherIsExceededAndUnlimitedEscsKeepTheirDuty) {
  VehicleParams p = Load("paper_hex");
  p.esc.current_limit_A = 25.0;
  p.battery.max_current_A = 100.0;
  RngStream rng(11, "limits");
  int esc_cases = 0, battery_cases = 0;
  for (int trial = 0; trial < 400; ++trial) {
    PowertrainState s = InitialPowertrainState(p);
    s.soc = 0.2 + 0.8 * rng.Uniform();
    std::vector<double> cmd(p.rotors.size());
    for (size_t i = 0; i < cmd.size(); ++i) {
      cmd[i] = rng.Uniform();
      s.omega_radps[i] = 700.0 * rng.Uniform();
    }
    const PowertrainOutput out = EvaluatePowertrain(p, s, cmd);
    EXPECT_LE(out.battery_A, 100.0 * (1.0 + 1e-9));
    for (size_t i = 0; i < cmd.size(); ++i) {
      const MotorOperatingPoint& m = out.motors[i];
      EXPECT_LE(m.dc_A, 25.0 * (1.0 + 1e-9));
      if (!m.current_limited) {
        EXPECT_EQ(m.duty, p.esc.Duty(cmd[i]));
      }
    }
    esc_cases += out.esc_limited > 0 ? 1 : 0;
    battery_cases += out.battery_limited ? 1 : 0;
  }
  EXPECT_GT(esc_cases, 20);  // the sample exercised both limits
  EXPECT_GT(battery_cases, 20);
}

TEST(CurrentLimits, GivenAnEscLimitWhenTheSteadyThrustAtFullCommandIsAskedThenItIsTheThrustAtTheLimit) {
  VehicleParams p = Load("paper_hex");
  const double V = p.battery.OpenCircuitVoltage_V(0.9);
  const double omega = SteadyOmegaAtDcCurrent_radps(p, 0, p.esc.current_limit_A, V);
  EXPECT_NEAR(ThrustForCommand(p, 0, 1.0, V), p.rotors[0].k_T_Nprps2 * omega * omega, 1e-9);
  // And the speed is consistent: at that speed, steady, the ESC draws the limit.
  const double Kt = p.motor.Kt_Nm_per_A();
  const double I_w = p.motor.no_load_current_A + p.rotors[0].k_Q_Nmprps2 * omega * omega / Kt;
  const double V_m = Kt * omega + I_w * p.motor.winding_resistance_ohm;
  EXPECT_NEAR(V_m * I_w / (p.esc.efficiency * V), p.esc.current_limit_A, 1e-6);
  p.esc.current_limit_A = std::numeric_limits<double>::infinity();
  EXPECT_GT(ThrustForCommand(p, 0, 1.0, V), p.rotors[0].k_T_Nprps2 * omega * omega * 1.2);
}

}  // namespace
}  // namespace hexsim::vehicle
