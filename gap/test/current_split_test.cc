// How the compass replay splits a battery current over the motors when the log has no per-motor
// currents (kShareExponent): I_i ∝ u_i^p, p in [0, 3], and the fit of p to the battery current.
#include <cmath>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "../src/compass_sampler.h"
#include "../src/nuisance.h"
#include "hexsim/vehicle/vehicle_io.h"

namespace hexsim::gap {
namespace {

vehicle::VehicleParams QuadX() {
  auto v = vehicle::LoadVehicleFile(std::string(HEXSIM_SOURCE_DIR) + "/worlds/vehicles/quad_x.yaml");
  EXPECT_TRUE(v.ok()) << v.status().message();
  return v.ok() ? *v : vehicle::VehicleParams{};
}

// Ten rows at 10 Hz, level, a steady 20.4 A and four different motor outputs; a new compass
// sample on every row.
logs::FlightLog SteadyLog(const std::vector<double>& u) {
  logs::FlightLog log;
  for (int r = 0; r < 10; ++r) {
    log.AppendRow();
    log.Set("t_s", 0.1 * r);
    log.Set("q_w", 1.0);
    log.Set("q_x", 0.0);
    log.Set("q_y", 0.0);
    log.Set("q_z", 0.0);
    log.Set("mag2_x_uT", 20.0 + 0.01 * r);
    log.Set("mag2_y_uT", 1.0);
    log.Set("mag2_z_uT", 43.0);
    log.Set("current_A", 20.4);
    for (size_t m = 0; m < u.size(); ++m) log.Set(fmt::format("motor_{}_u", m + 1), u[m]);
  }
  return log;
}

internal::LogInputs Inputs(const logs::FlightLog& log, size_t motors) {
  internal::LogInputs in;
  for (const char* c : {"q_w", "q_x", "q_y", "q_z"}) in.q.push_back(&log.Column(c));
  in.current = &log.Column("current_A");
  for (size_t m = 0; m < motors; ++m) in.motor_u.push_back(&log.Column(fmt::format("motor_{}_u", m + 1)));
  in.has_attitude = true;
  return in;
}

TEST(GapCurrentSplit, GivenNoPerMotorCurrents_WhenReplayed_ThenTheMotorsShareTheBatteryCurrentAsTheirOutputsToTheExponent) {
  const vehicle::VehicleParams v = QuadX();
  ASSERT_EQ(v.rotors.size(), 4u);
  const std::vector<double> u = {0.40, 0.50, 0.60, 0.70};
  const logs::FlightLog log = SteadyLog(u);
  const internal::LogInputs in = Inputs(log, u.size());
  const double motors_A = 20.4 - v.avionics_current_A;
  for (double p : {internal::kShareExponentLo, internal::kShareExponent, internal::kShareExponentHi}) {
    internal::CompassSampler sampler(log, v, 1, in, internal::Vec3(20, 1, 43), false, p);
    ASSERT_GT(sampler.samples().size(), 3u);
    sampler.Begin(0.0, 0.0, 0.0);
    internal::LocatedSample ls;
    ASSERT_TRUE(sampler.Locate(sampler.samples()[2], &ls));
    double sum = 0;
    for (double x : u) sum += std::pow(x, p);
    double total = 0;
    for (size_t m = 0; m < u.size(); ++m) {
      EXPECT_NEAR(ls.currents.motor_A[m], motors_A * std::pow(u[m], p) / sum, 1e-9) << "p = " << p << ", motor " << m;
      total += ls.currents.motor_A[m];
    }
    EXPECT_NEAR(total, motors_A, 1e-9);
  }
  // Where the law cannot be fitted: the middle of its physical range (equal split, static cubic law).
  EXPECT_DOUBLE_EQ(internal::kShareExponentLo, 0.0);
  EXPECT_DOUBLE_EQ(internal::kShareExponentHi, 3.0);
  EXPECT_DOUBLE_EQ(internal::kShareExponent, 1.5);
}

TEST(GapCurrentSplit, GivenABatteryCurrentThatFollowsAPowerOfTheOutputs_WhenTheLawIsFitted_ThenItsExponentIsRecoveredAndZeroAmpsAreNotFitted) {
  const vehicle::VehicleParams v = QuadX();
  for (double p_true : {1.2, 2.0, 2.6}) {
    logs::FlightLog log;
    for (int r = 0; r < 300; ++r) {
      log.AppendRow();
      log.Set("t_s", 0.1 * r);
      double sum = 0;
      for (int m = 0; m < 4; ++m) {
        // Outputs that wander between 0.3 and 0.8, each motor its own way.
        const double u = 0.55 + 0.25 * std::sin(0.07 * r * (m + 1) + m);
        log.Set(fmt::format("motor_{}_u", m + 1), u);
        sum += std::pow(u, p_true);
      }
      log.Set("current_A", v.avionics_current_A + 12.0 * sum);
      log.Set("q_w", 1.0);
      log.Set("q_x", 0.0);
      log.Set("q_y", 0.0);
      log.Set("q_z", 0.0);
    }
    const internal::LogInputs in = Inputs(log, 4);
    const std::vector<realdata::RowKind> kinds(log.rows(), realdata::RowKind::kFlight);
    EXPECT_NEAR(internal::FitShareExponent(log, in, v, kinds, 0.0), p_true, 0.026) << p_true;
    // Too few flight rows: not fitted.
    std::vector<realdata::RowKind> few(log.rows(), realdata::RowKind::kGround);
    for (size_t i = 0; i < 50; ++i) few[i] = realdata::RowKind::kFlight;
    EXPECT_TRUE(std::isnan(internal::FitShareExponent(log, in, v, few, 0.0)));
    // No power monitor (ArduPilot logs 0 A): no law to fit, whatever the outputs do.
    std::fill(log.MutableColumn(static_cast<size_t>(log.ColumnIndex("current_A"))).begin(),
              log.MutableColumn(static_cast<size_t>(log.ColumnIndex("current_A"))).end(), 0.0);
    EXPECT_TRUE(std::isnan(internal::FitShareExponent(log, in, v, kinds, 0.0)));
  }
}

}  // namespace
}  // namespace hexsim::gap
