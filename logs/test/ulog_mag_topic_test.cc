// Which magnetometer topic a ULog compass is imported from: PX4 may log sensor_mag and
// vehicle_magnetometer at different rates (a public log holds 1 Hz sensor_mag beside 2 Hz
// vehicle_magnetometer), and the compass must take the one with more samples in the flight.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "hexsim/logs/ulog_import.h"
#include "support/ulog_writer.h"

namespace hexsim::logs {
namespace {

using testing::Pack;
using testing::ULogWriter;

constexpr uint64_t kUs = 1000000;

// 10 s of level attitude at 10 Hz from t = 1 s, armed from 2 s to 9 s (actuator_armed), CAL_MAG0
// internal (ROT −1, device 5) and CAL_MAG1 external (ROT 0, device 6). Compass 0 (device 5):
// sensor_mag at 10 Hz while disarmed but `armed_raw_hz` while armed, vehicle_magnetometer at
// `calibrated_hz` throughout. Compass 1 (device 6): sensor_mag at 10 Hz, vehicle_magnetometer at 2 Hz.
std::string WriteLog(double armed_raw_hz, double calibrated_hz) {
  ULogWriter w;
  w.ParamInt("CAL_MAG0_ID", 5);
  w.ParamInt("CAL_MAG0_ROT", -1);
  w.ParamInt("CAL_MAG1_ID", 6);
  w.ParamInt("CAL_MAG1_ROT", 0);
  w.Format("vehicle_attitude:uint64_t timestamp;float[4] q;");
  w.Format("actuator_armed:uint64_t timestamp;bool armed;bool prearmed;uint8_t[6] _padding0;");
  w.Format("sensor_mag:uint64_t timestamp;uint32_t device_id;float x;float y;float z;");
  w.Format("vehicle_magnetometer:uint64_t timestamp;uint32_t device_id;float[3] magnetometer_ga;");
  const uint16_t att = w.Subscribe("vehicle_attitude", 0), aa = w.Subscribe("actuator_armed", 0);
  const uint16_t sm0 = w.Subscribe("sensor_mag", 0), sm1 = w.Subscribe("sensor_mag", 1);
  // The calibrated instances in the other order: matched to sensor_mag by device id, not instance.
  const uint16_t vm1 = w.Subscribe("vehicle_magnetometer", 0), vm0 = w.Subscribe("vehicle_magnetometer", 1);
  for (int k = 0; k <= 100; ++k) {
    w.Data(att, Pack<uint64_t>(kUs + 100000ull * static_cast<uint64_t>(k)) + Pack(1.0f) + Pack(0.0f) + Pack(0.0f) +
                    Pack(0.0f));
  }
  for (const auto& [t_us, on] : {std::pair<uint64_t, uint8_t>{kUs, 0}, {2 * kUs, 1}, {9 * kUs, 0}}) {
    w.Data(aa, Pack(t_us) + Pack(on) + Pack<uint8_t>(0) + std::string(6, '\0'));
  }
  auto mag = [&](uint16_t id, uint32_t device, double x_G, uint64_t t_us) {
    w.Data(id, Pack(t_us) + Pack(device) + Pack(static_cast<float>(x_G)) + Pack(0.0f) + Pack(0.4f));
  };
  for (uint64_t t = kUs + 50000; t < 11 * kUs; t += 100000) {
    const bool armed = t >= 2 * kUs && t < 9 * kUs;
    const uint64_t raw_step = static_cast<uint64_t>(1e6 / armed_raw_hz);
    if (!armed || (t - 2 * kUs) % raw_step < 100000) mag(sm0, 5, 0.21, t);
    mag(sm1, 6, 0.31, t);
  }
  const uint64_t cal_step = static_cast<uint64_t>(1e6 / calibrated_hz);
  for (uint64_t t = kUs + 60000; t < 11 * kUs; t += cal_step) mag(vm0, 5, 0.2, t);
  for (uint64_t t = kUs + 70000; t < 11 * kUs; t += 500000) mag(vm1, 6, 0.3, t);
  return w.bytes();
}

TEST(ULogMagTopic, GivenASlowRawTopicInFlight_WhenImported_ThenEachCompassTakesTheTopicWithMoreFlightSamples) {
  // Compass 0: sensor_mag 1 Hz in flight (7 records, more than vehicle_magnetometer's 20 over the
  // whole log with its 10 Hz ground time), vehicle_magnetometer 2 Hz (14 in flight).
  auto r = ImportULog(WriteLog(1.0, 2.0), "m.ulg");
  ASSERT_TRUE(r.ok()) << r.status().message();
  const auto& c = r->log.meta["compasses"];
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[0]["source"], "vehicle_magnetometer");
  EXPECT_EQ(c[0]["device_id"], 5.0);
  EXPECT_NE(c[0]["source_choice"].get<std::string>().find("14 records while armed against sensor_mag's 7"),
            std::string::npos)
      << c[0]["source_choice"];
  EXPECT_NEAR(r->log.Column("mag_x_uT")[50], 20.0, 1e-4);  // the calibrated topic's 0.2 G
  // Compass 1: sensor_mag 10 Hz (70 in flight) against vehicle_magnetometer's 2 Hz.
  EXPECT_EQ(c[1]["source"], "sensor_mag");
  EXPECT_NEAR(r->log.Column("mag2_x_uT")[50], 31.0, 1e-4);
  // Internal or external, from CAL_MAGn_ROT of each compass's calibration slot.
  EXPECT_EQ(c[0]["external"], false);
  EXPECT_EQ(c[1]["external"], true);
  EXPECT_NE(c[1]["external_source"].get<std::string>().find("CAL_MAG1_ROT"), std::string::npos);
}

TEST(ULogMagTopic, GivenEqualFlightCounts_WhenImported_ThenTheCalibratedTopicIsTaken) {
  auto r = ImportULog(WriteLog(2.0, 2.0), "e.ulg");
  ASSERT_TRUE(r.ok()) << r.status().message();
  const auto& c = r->log.meta["compasses"];
  EXPECT_EQ(c[0]["source"], "vehicle_magnetometer");
  EXPECT_NE(c[0]["source_choice"].get<std::string>().find("equal"), std::string::npos) << c[0]["source_choice"];
  // A faster raw topic in flight wins.
  r = ImportULog(WriteLog(5.0, 2.0), "f.ulg");
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_EQ(r->log.meta["compasses"][0]["source"], "sensor_mag");
}

}  // namespace
}  // namespace hexsim::logs
