// The dynamics channel's floor (its residual's variance above ~4 Hz) against the measured
// accelerometer's own variance there (DiagnoseOptions::max_floor_over_measured): a replay whose fast
// response is wrong raises the floor with its own error, and "no gap" cannot be told against it (a
// 12S quad replayed as quad_x read "no gap: residual at the noise floor" with a 26 m/s^2 floor).
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "../src/channels.h"
#include "../src/verdict.h"
#include "hexsim/common/rng.h"
#include "hexsim/logs/flight_log.h"

namespace hexsim::gap {
namespace {

constexpr int kRows = 6000;  // 60 s at 100 Hz

logs::FlightLog Rows() {
  logs::FlightLog log;
  const size_t t = log.AddColumn("t_s");
  for (int k = 0; k < kRows; ++k) {
    log.AppendRow();
    log.Set(t, 0.01 * k);
  }
  return log;
}

// The accelerometer reads gravity plus its own noise (sigma_sensor, white); the replay predicts
// gravity plus its own fast error (sigma_replay, white, independent of the sensor's).
internal::ChannelData Dynamics(double sigma_sensor, double sigma_replay, uint64_t seed) {
  RngStream rng(seed, "dynamics_floor_test");
  internal::ChannelData ch;
  ch.name = "dynamics";
  ch.unit = "m/s^2";
  ch.explain_above_noise = true;
  for (int k = 0; k < kRows; ++k) {
    const Eigen::Vector3d noise(rng.Normal(0, sigma_sensor), rng.Normal(0, sigma_sensor), rng.Normal(0, sigma_sensor));
    const Eigen::Vector3d replay_error(rng.Normal(0, sigma_replay), rng.Normal(0, sigma_replay), rng.Normal(0, sigma_replay));
    const Eigen::Vector3d measured = Eigen::Vector3d(0, 0, -9.81) + noise;
    const Eigen::Vector3d predicted = Eigen::Vector3d(0, 0, -9.81) + replay_error;
    ch.t.push_back(0.01 * k);
    ch.row.push_back(k);
    ch.measured.push_back(measured);
    ch.y.emplace_back(measured - predicted);
  }
  return ch;
}

ChannelResult Analyze(const internal::ChannelData& ch) {
  const logs::FlightLog log = Rows();
  const std::vector<std::string> phases(kRows, "cruise");
  RngStream rng(7, "dynamics_floor_test.analyze");
  return internal::AnalyzeInertial(ch, log, phases, DiagnoseOptions{}, &rng);
}

TEST(GapDynamicsFloor, GivenAReplayWithoutFastError_WhenAnalyzed_ThenTheFloorIsTheSensorsAndThereIsNoGap) {
  const ChannelResult r = Analyze(Dynamics(0.3, 0.0, 1));
  EXPECT_EQ(r.verdict, "none") << r.explanation;
  EXPECT_NEAR(r.noise_rms / r.measured_floor_rms, 1.0, 0.05);
}

TEST(GapDynamicsFloor, GivenAReplayWhoseFastErrorExceedsTheSensorsOwn_WhenAnalyzed_ThenItIsAModelMismatchNotNoGap) {
  const ChannelResult r = Analyze(Dynamics(0.3, 1.5, 2));
  EXPECT_TRUE(r.gap_detected);
  EXPECT_EQ(r.verdict, "unexplained");
  EXPECT_NE(r.explanation.find("model mismatch"), std::string::npos) << r.explanation;
  EXPECT_GT(r.noise_rms, 4.0 * r.measured_floor_rms);
}

}  // namespace
}  // namespace hexsim::gap
