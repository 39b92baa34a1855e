#include "hexsim/control/pid.h"

#include <cmath>

#include <gtest/gtest.h>

namespace hexsim::control {
namespace {

TEST(PidTest, GivenUnreachableSetpoint_WhenSaturatedForLong_ThenIntegratorStopsAtTheOutputLimit) {
  PidGains g;
  g.kp = 1.0;
  g.ki = 5.0;
  g.output_limit = 2.0;  // integrator_limit left infinite: only the anti-windup bounds it
  Pid pid(g);
  const double dt = 0.01, error = 1.0;
  for (int i = 0; i < 1000; ++i) pid.Update(error, 0.0, dt);  // 10 s: a naive integrator reaches 50
  // Conditional integration stops once kp·e + I ≥ limit, plus at most one step's increment.
  EXPECT_LE(pid.integrator(), g.output_limit - g.kp * error + g.ki * error * dt + 1e-12);
  EXPECT_NEAR(pid.Update(error, 0.0, dt), g.output_limit, g.ki * error * dt);  // held at the limit
  // When the error reverses, the output leaves saturation at once (no wound-up integrator to unwind).
  const double u = pid.Update(-1.0, 0.0, dt);
  EXPECT_LT(u, 0.0);
}

TEST(PidTest, GivenIntegratorLimit_WhenErrorPersists_ThenIntegratorIsClamped) {
  PidGains g;
  g.ki = 10.0;
  g.integrator_limit = 0.3;
  Pid pid(g);
  for (int i = 0; i < 500; ++i) pid.Update(-1.0, 0.0, 0.01);
  EXPECT_DOUBLE_EQ(pid.integrator(), -0.3);
}

TEST(PidTest, GivenSetpointStep_WhenDerivativeIsOnMeasurement_ThenThereIsNoDerivativeKick) {
  PidGains g;
  g.kp = 2.0;
  g.kd = 100.0;
  Pid pid(g);
  pid.Update(0.0, 0.0, 0.01);
  const double u = pid.Update(10.0, 0.0, 0.01);  // setpoint jumps, measurement does not move
  EXPECT_DOUBLE_EQ(u, g.kp * 10.0);
}

TEST(PidTest, GivenMeasurementRamp_WhenFiltered_ThenDerivativeSettlesToMinusKdTimesSlope) {
  PidGains g;
  g.kd = 0.5;
  g.d_filter_hz = 5.0;  // τ = 1/(2π·5) ≈ 32 ms
  Pid pid(g);
  const double slope = 3.0, dt = 0.001;
  double u = 0.0;
  for (int i = 0; i <= 500; ++i) u = pid.Update(0.0, slope * i * dt, dt);  // 0.5 s ≈ 16 τ
  EXPECT_NEAR(u, -g.kd * slope, 1e-4 * g.kd * slope);
}

TEST(PidTest, GivenFirstOrderPlantWithConstantDisturbance_WhenPiControlled_ThenSteadyStateErrorVanishes) {
  // ẋ = u − d: a P controller alone would settle at error d/kp; the integrator removes it.
  PidGains g;
  g.kp = 4.0;
  g.ki = 4.0;
  g.output_limit = 10.0;
  Pid pid(g);
  const double d = 1.5, dt = 0.001, r = 1.0;
  double x = 0.0;
  for (int i = 0; i < 10000; ++i) x += (pid.Update(r, x, dt) - d) * dt;  // 10 s ≫ the closed-loop 0.5 s
  EXPECT_NEAR(x, r, 1e-3);
  EXPECT_NEAR(pid.integrator(), d, 1e-2);
}

TEST(PidTest, GivenAnAbsurdGain_WhenKpTimesErrorOverflows_ThenTheOutputIsTheFiniteLimitAndTheIntegratorStaysFinite) {
  // Numerical health: a gain of 1e300 on a 1e10 error overflows kp·e to +inf; the output must still
  // be the (finite) output limit and the integrator must not pick up the infinity.
  PidGains g;
  g.kp = 1e300;
  g.ki = 1e300;
  g.output_limit = 3.0;
  g.integrator_limit = 1.0;
  Pid pid(g);
  for (double error : {1e10, -1e10, 1e10}) {
    const double u = pid.Update(error, 0.0, 0.01);
    ASSERT_TRUE(std::isfinite(u));
    EXPECT_EQ(u, std::copysign(g.output_limit, error));
    EXPECT_TRUE(pid.saturated());
    EXPECT_LE(std::fabs(pid.integrator()), g.integrator_limit);
  }
}

}  // namespace
}  // namespace hexsim::control
