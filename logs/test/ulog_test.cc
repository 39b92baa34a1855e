// ULog parser and importer on a ULog file the test writes itself (support/ulog_writer.h).
#include "hexsim/logs/ulog.h"

#include <cmath>

#include <gtest/gtest.h>

#include "hexsim/logs/mag_input.h"
#include "hexsim/logs/ulog_import.h"
#include "support/ulog_writer.h"

namespace hexsim::logs {
namespace {

using testing::Pack;
using testing::ULogWriter;

// 2 s of a level vehicle yawing at 90°/s: attitude at 50 Hz, two raw magnetometers at 10 Hz (the
// second with a known offset), battery and motor outputs, a nested type and padding on the way.
std::string WriteFlight(bool raw_mags) {
  ULogWriter w;
  w.Info("char[9] ver_sw", "v1.14.0x");
  w.Param("CA_ROTOR_COUNT", 4.0f);
  w.Format("vehicle_attitude:uint64_t timestamp;float[4] q;uint8_t[4] _padding0;");
  w.Format("vec3:float x;float y;float z;");
  w.Format("sensor_mag:uint64_t timestamp;uint32_t device_id;float x;float y;float z;float temperature;");
  w.Format("vehicle_magnetometer:uint64_t timestamp;float[3] magnetometer_ga;");
  w.Format("battery_status:uint64_t timestamp;float voltage_v;float current_a;");
  w.Format("actuator_motors:uint64_t timestamp;float[12] control;");
  w.Format("sensor_combined:uint64_t timestamp;float[3] gyro_rad;vec3 accel;");
  const uint16_t att = w.Subscribe("vehicle_attitude", 0);
  const uint16_t mag0 = w.Subscribe(raw_mags ? "sensor_mag" : "vehicle_magnetometer", 0);
  const uint16_t mag1 = raw_mags ? w.Subscribe("sensor_mag", 1) : uint16_t{0xFFFF};  // no raw topic at all otherwise
  const uint16_t bat = w.Subscribe("battery_status", 0);
  const uint16_t mot = w.Subscribe("actuator_motors", 0);
  const uint16_t imu = w.Subscribe("sensor_combined", 0);
  for (int k = 0; k <= 100; ++k) {
    const uint64_t t_us = 2000000 + 20000ull * static_cast<uint64_t>(k);
    const double yaw = 0.5 * M_PI * k * 0.02;  // rad
    w.Data(att, Pack(t_us) + Pack<float>(static_cast<float>(std::cos(yaw / 2))) + Pack<float>(0) + Pack<float>(0) +
                    Pack<float>(static_cast<float>(std::sin(yaw / 2))) + std::string(4, '\0'));
    w.Data(imu, Pack(t_us) + Pack<float>(0) + Pack<float>(0) + Pack<float>(1.5708f) + Pack<float>(0) + Pack<float>(0) +
                    Pack<float>(-9.81f));
    if (k % 5 == 0) {
      // Earth field 0.2 G north, 0.4 G down, seen in the body of a vehicle at `yaw`.
      const float bx = static_cast<float>(0.2 * std::cos(yaw)), by = static_cast<float>(-0.2 * std::sin(yaw));
      if (raw_mags) {
        w.Data(mag0, Pack(t_us + 1000) + Pack<uint32_t>(7) + Pack(bx) + Pack(by) + Pack(0.4f) + Pack(30.0f));
      } else {
        w.Data(mag0, Pack(t_us + 1000) + Pack(bx) + Pack(by) + Pack(0.4f));
      }
      if (raw_mags) w.Data(mag1, Pack(t_us + 2000) + Pack<uint32_t>(8) + Pack(bx + 0.1f) + Pack(by) + Pack(0.4f) + Pack(31.0f));
      w.Data(bat, Pack(t_us) + Pack(16.0f) + Pack(12.5f));
      std::string ctl = Pack(t_us);
      for (int m = 0; m < 12; ++m) ctl += Pack(m < 4 ? 0.45f : std::nanf(""));
      w.Data(mot, ctl);
    }
  }
  w.Message('L', std::string("\x06", 1) + Pack<uint64_t>(2500000) + "armed");
  return w.bytes();
}

TEST(ULog, GivenAWrittenFile_WhenParsed_ThenTopicsFieldsAndParametersComeBack) {
  auto u = ParseULog(WriteFlight(true), "t.ulg");
  ASSERT_TRUE(u.ok()) << u.status().message();
  EXPECT_EQ(u->info.at("ver_sw"), "v1.14.0x");
  EXPECT_EQ(u->params.at("CA_ROTOR_COUNT"), 4.0);
  const ULogTopic* att = u->Find("vehicle_attitude");
  ASSERT_NE(att, nullptr);
  EXPECT_EQ(att->records.size(), 101u);
  EXPECT_EQ(att->record_size, 28u);
  EXPECT_FALSE(att->Has("_padding0[0]"));
  EXPECT_DOUBLE_EQ(att->TimeS(1), 2.02);
  const ULogTopic* imu = u->Find("sensor_combined");
  ASSERT_NE(imu, nullptr);
  EXPECT_FLOAT_EQ(static_cast<float>(imu->Get(0, "accel.z")), -9.81f);  // nested type
  ASSERT_NE(u->Find("sensor_mag", 1), nullptr);
  EXPECT_EQ(u->Find("sensor_mag", 1)->Get(0, "device_id"), 8.0);
  EXPECT_EQ(u->messages, std::vector<std::string>{"armed"});
  EXPECT_EQ(u->bytes_skipped, 0u);
}

TEST(ULog, GivenAWrittenFile_WhenImported_ThenAFlightLogWithAttitudeCompassesBatteryAndMotors) {
  auto r = ImportULog(WriteFlight(true), "t.ulg");
  ASSERT_TRUE(r.ok()) << r.status().message();
  const FlightLog& log = r->log;
  EXPECT_EQ(log.rows(), 101u);
  EXPECT_TRUE(r->warnings.empty());
  EXPECT_NEAR(log.Column("yaw_deg")[25], 45.0, 1e-3);
  // Sample-and-hold: the row at 2.04 s holds the magnetometer sample of 2.001 s.
  EXPECT_NEAR(log.Column("mag_t_s")[2], 2.001, 1e-9);
  EXPECT_TRUE(std::isnan(log.Column("mag_x_uT")[0]));  // before the first sample
  EXPECT_NEAR(log.Column("mag_x_uT")[1], 20.0, 1e-4);    // 0.2 G
  EXPECT_NEAR(log.Column("mag2_x_uT")[1], 30.0, 1e-4);
  EXPECT_NEAR(log.Column("current_A")[10], 12.5, 1e-6);
  EXPECT_NEAR(log.Column("motor_4_u")[10], 0.45, 1e-6);
  EXPECT_FALSE(log.Has("motor_5_u"));
  EXPECT_NEAR(log.Column("gyro_z_radps")[3], 1.5708, 1e-5);
  EXPECT_EQ(log.meta["format"], "px4-ulog");
  // The FlightLog round-trips through CSV, and calibrate's input side reads the .ulg.
  auto back = ParseFlightLogCsv(FlightLogToCsv(log), "t.csv");
  ASSERT_TRUE(back.ok()) << back.status().message();
  EXPECT_EQ(back->rows(), log.rows());
  auto in = ParseMagInput(WriteFlight(true), "t.ulg", "mag2");
  ASSERT_TRUE(in.ok()) << in.status().message();
  EXPECT_EQ(in->format, "ulog");
  EXPECT_EQ(in->field.size(), 20u);  // the 21st (4.002 s) comes after the last row (4.0 s)
}

TEST(ULog, GivenOnlyTheCalibratedTopic_WhenImported_ThenItIsUsedAndSaidSo) {
  auto r = ImportULog(WriteFlight(false), "t.ulg");
  ASSERT_TRUE(r.ok()) << r.status().message();
  ASSERT_EQ(r->warnings.size(), 1u);
  EXPECT_NE(r->warnings[0].find("vehicle_magnetometer"), std::string::npos);
  EXPECT_NE(r->warnings[0].find("already calibrated"), std::string::npos);
  EXPECT_NEAR(r->log.Column("mag_z_uT")[1], 40.0, 1e-4);
}

TEST(ULog, GivenDamagedOrForeignBytes_WhenImported_ThenBadInputOrSkippedNeverACrash) {
  EXPECT_EQ(ImportULog("not a log", "x.ulg").status().code(), StatusCode::kBadInput);
  std::string bytes = WriteFlight(true);
  auto cut = ImportULog(bytes.substr(0, bytes.size() - 7), "cut.ulg");  // truncated mid-message
  ASSERT_TRUE(cut.ok()) << cut.status().message();
  EXPECT_GT(cut->log.meta["bytes_skipped"].get<size_t>(), 0u);
  ULogWriter w;
  w.Format("vehicle_attitude:uint64_t timestamp;float[4] q;");
  EXPECT_EQ(ImportULog(w.bytes(), "empty.ulg").status().code(), StatusCode::kBadInput);
  w.Format("loop:loop a;");  // a format that contains itself
  w.Subscribe("loop", 0);
  EXPECT_EQ(ImportULog(w.bytes(), "loop.ulg").status().code(), StatusCode::kBadInput);
}

// A level vehicle's attitude at 10 Hz for `seconds`, from `t0_us`, into `w` (msg_id `att`).
void Attitudes(ULogWriter* w, uint16_t att, uint64_t t0_us, int n) {
  for (int k = 0; k < n; ++k) {
    const uint64_t t_us = t0_us + 100000ull * static_cast<uint64_t>(k);
    w->Data(att, Pack(t_us) + Pack<float>(1) + Pack<float>(0) + Pack<float>(0) + Pack<float>(0));
  }
}

std::string SyncMessage() {
  const char magic[8] = {0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, static_cast<char>(0xBB), 0x12};
  return Pack<uint16_t>(8) + "S" + std::string(magic, 8);
}

TEST(ULog, GivenGarbageInsideTheFileBeforeASyncMessage_WhenImported_ThenTheDataAfterItIsReadAndTheDamageIsNamed) {
  // Given: 5 s of attitude, 300 bytes where no message starts (an unknown type, then a size that
  // would reach past the end of the file), a sync message, 5 more seconds
  ULogWriter w;
  w.Format("vehicle_attitude:uint64_t timestamp;float[4] q;");
  const uint16_t att = w.Subscribe("vehicle_attitude", 0);
  Attitudes(&w, att, 1000000, 50);
  const std::string before = w.bytes();
  Attitudes(&w, att, 6000000, 50);
  std::string garbage = Pack<uint16_t>(40) + "#" + std::string(37, '\x5a');
  garbage += Pack<uint16_t>(65000) + "D" + std::string(257, '\x11');
  const std::string bytes = before + garbage + SyncMessage() + w.bytes().substr(before.size());
  // When
  auto r = ImportULog(bytes, "damaged.ulg");
  // Then: all 100 rows, the damage counted as damage (not as a truncated file)
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_EQ(r->log.rows(), 100u);
  EXPECT_EQ(r->log.meta["bytes_damaged"].get<size_t>(), garbage.size());
  EXPECT_EQ(r->log.meta["bytes_skipped"].get<size_t>(), 0u);
  ASSERT_EQ(r->warnings.size(), 1u);
  EXPECT_NE(r->warnings[0].find("damaged: 300 bytes in 1 places"), std::string::npos) << r->warnings[0];
  EXPECT_EQ(r->warnings[0].find("truncated"), std::string::npos) << r->warnings[0];
}

TEST(ULog, GivenDataOfASubscriptionItCannotReadAndOfNone_WhenParsed_ThenOnlyTheUnsubscribedIsDamage) {
  // Given: a subscription to a format with an unknown type (its data is skipped quietly), and one
  // data message whose msg_id no subscription has (damage: the parser resumes at the next sync)
  ULogWriter w;
  w.Format("vehicle_attitude:uint64_t timestamp;float[4] q;");
  w.Format("odd:uint64_t timestamp;quaternion_t q;");
  const uint16_t att = w.Subscribe("vehicle_attitude", 0);
  const uint16_t odd = w.Subscribe("odd", 0);
  for (int k = 0; k < 10; ++k) w.Data(odd, Pack<uint64_t>(1000000 + k) + std::string(16, '\0'));
  Attitudes(&w, att, 1000000, 20);
  const std::string before = w.bytes();
  Attitudes(&w, att, 3000000, 20);
  const std::string stray = Pack<uint16_t>(10) + "D" + Pack<uint16_t>(77) + std::string(8, '\0');
  const std::string bytes = before + stray + SyncMessage() + w.bytes().substr(before.size());
  // When
  auto u = ParseULog(bytes, "stray.ulg");
  // Then
  ASSERT_TRUE(u.ok()) << u.status().message();
  EXPECT_EQ(u->bytes_damaged, stray.size());
  EXPECT_EQ(u->damaged_runs, 1u);
  ASSERT_NE(u->Find("vehicle_attitude"), nullptr);
  EXPECT_EQ(u->Find("vehicle_attitude")->records.size(), 40u);
}

TEST(ULog, GivenABatteryWithoutACurrent_WhenImported_ThenThereIsNoCurrentNotMinusOneAmp) {
  // Given: PX4's battery_status of a voltage-only monitor: current_a -1 ("-1 if unknown")
  ULogWriter w;
  w.Format("vehicle_attitude:uint64_t timestamp;float[4] q;");
  w.Format("battery_status:uint64_t timestamp;float voltage_v;float current_a;");
  const uint16_t att = w.Subscribe("vehicle_attitude", 0);
  const uint16_t bat = w.Subscribe("battery_status", 0);
  Attitudes(&w, att, 1000000, 30);
  for (int k = 0; k < 30; ++k) w.Data(bat, Pack<uint64_t>(1000000 + 100000ull * k) + Pack(15.9f) + Pack(-1.0f));
  // When
  auto r = ImportULog(w.bytes(), "volts.ulg");
  // Then
  ASSERT_TRUE(r.ok()) << r.status().message();
  for (double a : r->log.Column("current_A")) EXPECT_FALSE(std::isfinite(a)) << a;
  EXPECT_FALSE(r->log.meta["current_usable"].get<bool>());
  EXPECT_NE(r->log.meta["current_unusable_why"].get<std::string>().find("the log has no current"), std::string::npos)
      << r->log.meta["current_unusable_why"];
}

}  // namespace
}  // namespace hexsim::logs
