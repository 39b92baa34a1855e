// The compass replay's samples (compass_sampler.h) from a PX4 log's raw sensor_mag: gap reads every
// real log as the autopilot's calibrated body-frame field, so a raw column is calibrated as PX4 does,
// R·S·(raw − off), from the meta's px4_calibration (ulog_import.h).
#include <cmath>
#include <string>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "../src/compass_sampler.h"
#include "hexsim/vehicle/vehicle_io.h"

namespace hexsim::gap {
namespace {

TEST(GapCompassSampler, GivenAPx4RawSensorMagColumn_WhenSampled_ThenItIsCalibratedIntoTheBodyFrameAsPx4Does) {
  auto v = vehicle::LoadVehicleFile(std::string(HEXSIM_SOURCE_DIR) + "/worlds/vehicles/quad_x.yaml");
  ASSERT_TRUE(v.ok()) << v.status().message();
  const internal::Vec3 raw(30.0, -12.0, 41.0), off_G(0.05, -0.02, 0.1);
  logs::FlightLog log;
  for (int r = 0; r < 5; ++r) {
    log.AppendRow();
    log.Set("t_s", 0.1 * r);
    log.Set("q_w", 1.0);
    log.Set("q_x", 0.0);
    log.Set("q_y", 0.0);
    log.Set("q_z", 0.0);
    log.Set("mag2_x_uT", raw(0) + r);  // a new sample on every row
    log.Set("mag2_y_uT", raw(1));
    log.Set("mag2_z_uT", raw(2));
  }
  // luk8426/flugdrohne's external compass: CAL_MAG1_ROT 10 (roll 180, yaw 90).
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  Eigen::Matrix3d S;
  S << 1.05, 0.02, 0.0, 0.02, 0.97, 0.01, 0.0, 0.01, 1.02;
  nlohmann::json cal = {{"rotation_known", true},
                        {"rotation_matrix", {R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2)}},
                        {"scales", {1.05, 0.97, 1.02}},
                        {"offdiagonals", {0.02, 0.0, 0.01}},
                        {"offsets_G", {off_G(0), off_G(1), off_G(2)}}};
  log.meta["compasses"] = {{{"column", "mag2"}, {"frame", "raw"}, {"px4_calibration", cal}}};
  internal::LogInputs in;
  for (const char* c : {"q_w", "q_x", "q_y", "q_z"}) in.q.push_back(&log.Column(c));
  in.has_attitude = true;
  const internal::CompassSampler sampler(log, *v, 1, in, internal::Vec3(20, 1, 43), true, internal::kShareExponent);
  ASSERT_EQ(sampler.samples().size(), 5u);
  for (int r = 0; r < 5; ++r) {
    const internal::Vec3 want = R * S * (raw + internal::Vec3(r, 0, 0) - 100.0 * off_G);
    EXPECT_TRUE(sampler.samples()[static_cast<size_t>(r)].m.isApprox(want, 1e-9)) << sampler.samples()[static_cast<size_t>(r)].m;
  }
  // A calibrated topic (frame "calibrated") is read as logged.
  log.meta["compasses"][0]["frame"] = "calibrated";
  const internal::CompassSampler as_logged(log, *v, 1, in, internal::Vec3(20, 1, 43), true, internal::kShareExponent);
  EXPECT_TRUE(as_logged.samples()[0].m.isApprox(raw, 1e-12)) << as_logged.samples()[0].m;
}

}  // namespace
}  // namespace hexsim::gap
