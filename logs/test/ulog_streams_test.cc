// ULog import's native-rate streams and PX4's magnetometer calibration undone, on ULog files the
// test writes itself (support/ulog_writer.h).
#include <unistd.h>

#include <cmath>
#include <filesystem>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "hexsim/logs/dataflash_import.h"

#include "hexsim/logs/mag_input.h"
#include "hexsim/logs/ulog_import.h"
#include "support/ulog_writer.h"

namespace hexsim::logs {
namespace {

using testing::Pack;
using testing::ULogWriter;

// Attitude at 100 Hz, IMU at 200 Hz, raw mag at 50 Hz with one sample timed back (damage), battery
// at 5 Hz, GPS at 5 Hz without a fix for the first second, air data at 20 Hz; 3 s.
std::string MultiRate() {
  ULogWriter w;
  w.Format("vehicle_attitude:uint64_t timestamp;float[4] q;");
  w.Format("sensor_combined:uint64_t timestamp;float[3] gyro_rad;float[3] accelerometer_m_s2;");
  w.Format("sensor_mag:uint64_t timestamp;uint32_t device_id;float x;float y;float z;");
  w.Format("battery_status:uint64_t timestamp;float voltage_v;float current_a;");
  w.Format("vehicle_air_data:uint64_t timestamp;float baro_alt_meter;");
  w.Format("vehicle_gps_position:uint64_t timestamp;double latitude_deg;double longitude_deg;double altitude_msl_m;"
           "float vel_n_m_s;float vel_e_m_s;float vel_d_m_s;uint8_t fix_type;uint8_t[7] _padding0;");
  const uint16_t att = w.Subscribe("vehicle_attitude", 0), imu = w.Subscribe("sensor_combined", 0),
                 mag = w.Subscribe("sensor_mag", 0), bat = w.Subscribe("battery_status", 0),
                 air = w.Subscribe("vehicle_air_data", 0), gps = w.Subscribe("vehicle_gps_position", 0);
  for (uint64_t k = 0; k < 600; ++k) {  // 5 ms ticks
    const uint64_t t = 1000000 + 5000 * k;
    const float s = static_cast<float>(k);
    w.Data(imu, Pack(t) + Pack(0.001f * s) + Pack(0.0f) + Pack(0.0f) + Pack(0.0f) + Pack(0.0f) + Pack(-9.8f));
    if (k % 2 == 0) w.Data(att, Pack(t) + Pack(1.0f) + Pack(0.0f) + Pack(0.0f) + Pack(0.0f));
    if (k % 4 == 1) {
      const uint64_t tm = k == 201 ? t - 500000 : t;  // one sample timed back: dropped, never reordered
      w.Data(mag, Pack(tm) + Pack<uint32_t>(77) + Pack(0.2f + 1e-4f * s) + Pack(0.0f) + Pack(0.4f));
    }
    if (k % 40 == 0) w.Data(bat, Pack(t) + Pack(16.0f - 0.001f * s) + Pack(10.0f + 0.01f * s));
    if (k % 10 == 3) w.Data(air, Pack(t) + Pack(100.0f + 0.01f * s));
    if (k % 40 == 7) {
      // The logger drops the trailing padding: the record ends at fix_type.
      w.Data(gps, Pack(t) + Pack(47.0 + 1e-6 * s) + Pack(8.5) + Pack(500.0) + Pack(1.0f) + Pack(-2.0f) + Pack(0.5f) +
                      Pack<uint8_t>(k < 200 ? 2 : 3));
    }
  }
  return w.bytes();
}

TEST(ULogStreams, GivenSensorsAtTheirOwnRates_WhenImported_ThenEachStreamHoldsEverySampleAtItsOwnTime) {
  auto r = ImportULog(MultiRate(), "multi.ulg");
  ASSERT_TRUE(r.ok()) << r.status().message();
  const FlightLog& log = r->log;
  EXPECT_EQ(log.rows(), 300u);  // one per attitude sample
  struct Expect {
    const char* stream;
    size_t rows;
    const char* column;
  };
  for (const Expect& e : {Expect{"att", 300, "q_w"}, Expect{"imu", 600, "gyro_x_radps"}, Expect{"mag", 149, "mag_x_uT"},
                          Expect{"batt", 15, "current_A"}, Expect{"baro", 60, "baro_alt_m"}, Expect{"gps", 10, "lat_deg"}}) {
    const FlightLog* s = log.Stream(e.stream);
    ASSERT_NE(s, nullptr) << e.stream;
    EXPECT_EQ(s->rows(), e.rows) << e.stream;
    EXPECT_TRUE(s->Has(e.column)) << e.stream;
  }
  // Native samples, not resampled: the IMU's k-th row is the k-th written sample.
  const FlightLog& imu = *log.Stream("imu");
  EXPECT_DOUBLE_EQ(imu.Column("t_s")[123], 1.0 + 0.005 * 123);
  EXPECT_FLOAT_EQ(static_cast<float>(imu.Column("gyro_x_radps")[123]), 0.123f);
  // The mag sample timed back is dropped and counted; the rest keep their times and values.
  const FlightLog& mag = *log.Stream("mag");
  EXPECT_EQ(log.meta["stream_samples_dropped"].get<size_t>(), 1u);
  EXPECT_DOUBLE_EQ(mag.Column("t_s")[50], 1.0 + 0.005 * 205);
  EXPECT_NEAR(mag.Column("mag_x_uT")[50], 100.0 * (0.2 + 1e-4 * 205), 1e-3);
  // GPS: only 3-D fixes, degrees either way; the table holds its velocity, not its position.
  EXPECT_DOUBLE_EQ(log.Stream("gps")->Column("t_s")[0], 1.0 + 0.005 * 207);
  EXPECT_DOUBLE_EQ(log.Stream("gps")->Column("lon_deg")[0], 8.5);
  EXPECT_TRUE(log.Has("gps_vel_E_mps"));
  EXPECT_FALSE(log.Has("lat_deg"));
}

TEST(ULogStreams, GivenAnImportedULog_WhenWrittenAndReadBack_ThenEveryStreamComesBackUnchanged) {
  auto r = ImportULog(MultiRate(), "multi.ulg");
  ASSERT_TRUE(r.ok()) << r.status().message();
  const auto dir = std::filesystem::temp_directory_path() / ("hexsim_ulog_streams_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "log.csv").string();
  ASSERT_TRUE(WriteFlightLog(r->log, path).ok());
  auto back = ReadFlightLog(path);
  ASSERT_TRUE(back.ok()) << back.status().message();
  ASSERT_EQ(back->stream_names().size(), r->log.stream_names().size());
  for (const auto& name : r->log.stream_names()) {
    const FlightLog& a = *r->log.Stream(name);
    const FlightLog* b = back->Stream(name);
    ASSERT_NE(b, nullptr) << name;
    ASSERT_EQ(b->rows(), a.rows()) << name;
    ASSERT_EQ(b->columns(), a.columns()) << name;
    for (size_t c = 0; c < a.columns().size(); ++c) {
      for (size_t i = 0; i < a.rows(); ++i) {
        const double x = a.At(i, c), y = b->At(i, c);
        ASSERT_TRUE(x == y || (std::isnan(x) && std::isnan(y))) << name << " " << a.columns()[c] << " row " << i;
      }
    }
  }
  std::filesystem::remove_all(dir);
}

// PX4's correction with a stale calibration in slot 1 (CAL_MAG1_ID = the sensor's device id; slot 0
// holds another sensor): calibrated = R·S·(raw − off), R = yaw 90° (CAL_MAG1_ROT 2, external).
struct Px4Cal {
  Eigen::Vector3d off_G{0.10, -0.20, 0.30};
  Eigen::Matrix3d S = (Eigen::Matrix3d() << 1.05, 0.02, -0.01, 0.02, 0.97, 0.015, -0.01, 0.015, 1.0).finished();
  Eigen::Matrix3d R = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
};

// The raw readings (gauss): a spiral over the sphere, |B| = 0.5 G, plus a hard iron.
std::vector<Eigen::Vector3d> RawSpiral(int n) {
  std::vector<Eigen::Vector3d> raw;
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / n, rho = std::sqrt(1.0 - z * z), phi = 2.39996322972865332 * i;
    raw.emplace_back(0.5 * rho * std::cos(phi) + 0.15, 0.5 * rho * std::sin(phi) - 0.25, 0.5 * z + 0.2);
  }
  return raw;
}

std::string CalibratedLog(const Px4Cal& cal, const std::vector<Eigen::Vector3d>& raw) {
  ULogWriter w;
  w.ParamInt("CAL_MAG0_ID", 999);
  w.ParamInt("CAL_MAG1_ID", 4242);
  w.ParamInt("CAL_MAG1_ROT", 2);
  const char* axes[3] = {"X", "Y", "Z"};
  const int odi[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  for (int k = 0; k < 3; ++k) {
    w.Param(std::string("CAL_MAG1_") + axes[k] + "OFF", static_cast<float>(cal.off_G(k)));
    w.Param(std::string("CAL_MAG1_") + axes[k] + "SCALE", static_cast<float>(cal.S(k, k)));
    w.Param(std::string("CAL_MAG1_") + axes[k] + "ODIAG", static_cast<float>(cal.S(odi[k][0], odi[k][1])));
  }
  w.Format("vehicle_attitude:uint64_t timestamp;float[4] q;");
  w.Format("vehicle_magnetometer:uint64_t timestamp;uint64_t timestamp_sample;uint32_t device_id;"
           "float[3] magnetometer_ga;uint8_t calibration_count;uint8_t[3] _padding0;");
  const uint16_t att = w.Subscribe("vehicle_attitude", 0), vm = w.Subscribe("vehicle_magnetometer", 0);
  for (size_t i = 0; i < raw.size(); ++i) {
    const uint64_t t = 1000000 + 10000 * i;
    w.Data(att, Pack(t) + Pack(1.0f) + Pack(0.0f) + Pack(0.0f) + Pack(0.0f));
    const Eigen::Vector3f c = (cal.R * cal.S * (raw[i] - cal.off_G)).cast<float>();
    w.Data(vm, Pack(t + 1) + Pack(t) + Pack<uint32_t>(4242) + Pack(c(0)) + Pack(c(1)) + Pack(c(2)) + Pack<uint8_t>(1));
  }
  w.Data(att, Pack<uint64_t>(1000000 + 10000 * raw.size()) + Pack(1.0f) + Pack(0.0f) + Pack(0.0f) + Pack(0.0f));
  return w.bytes();
}

TEST(ULogPx4Calibration, GivenACalibratedTopicAndItsCalMagParams_WhenRead_ThenTheRawFieldIsRebuiltAndTheSlotFound) {
  const Px4Cal cal;
  const auto raw = RawSpiral(200);
  auto in = ParseMagInput(CalibratedLog(cal, raw), "cal.ulg", "mag");
  ASSERT_TRUE(in.ok()) << in.status().message();
  EXPECT_EQ(in->px4_index, 1);  // by device id, not by instance
  ASSERT_EQ(in->field.size(), raw.size());
  double worst_uT = 0.0;
  for (size_t i = 0; i < raw.size(); ++i) worst_uT = std::max(worst_uT, (in->field[i] - 100.0 * raw[i]).norm());
  EXPECT_LT(worst_uT, 1e-3);  // float precision of the logged values
  EXPECT_TRUE(in->prior_offset.isApprox(100.0 * cal.off_G, 1e-6));
  bool said = false;
  for (const auto& n : in->notes) said = said || n.find("rebuilt") != std::string::npos;
  EXPECT_TRUE(said);
}

TEST(ULogPx4Calibration, GivenAnUnknownRotation_WhenRead_ThenTheFieldIsLeftAsLoggedAndTheImportSaysRelative) {
  const Px4Cal cal;
  std::string bytes = CalibratedLog(cal, RawSpiral(20));
  ULogWriter extra;  // a later parameter message overrides the rotation with one PX4 renumbered
  extra.ParamInt("CAL_MAG1_ROT", 40);
  bytes += extra.bytes().substr(16);
  auto imp = ImportULog(bytes, "rot.ulg");
  ASSERT_TRUE(imp.ok()) << imp.status().message();
  ASSERT_EQ(imp->warnings.size(), 1u);
  EXPECT_NE(imp->warnings[0].find("relative to the one in force"), std::string::npos);
}

// PX4's vehicle_magnetometer is published after its samples are filtered (16 ms later in a public
// log): the compass stream is timed by timestamp_sample, which the diagnosis's latency is measured
// against; a topic without one keeps its publication time.
TEST(ULogStreams, GivenACompassPublishedAfterItWasSampled_WhenImported_ThenItsStreamIsTimedBySampleTime) {
  ULogWriter w;
  w.Format("vehicle_attitude:uint64_t timestamp;float[4] q;");
  w.Format("vehicle_magnetometer:uint64_t timestamp;uint64_t timestamp_sample;uint32_t device_id;"
           "float[3] magnetometer_ga;uint8_t calibration_count;uint8_t[3] _padding0;");
  const uint16_t att = w.Subscribe("vehicle_attitude", 0), vm = w.Subscribe("vehicle_magnetometer", 0);
  constexpr uint64_t kPublishLagUs = 16000;
  for (uint64_t k = 0; k < 100; ++k) {
    const uint64_t t = 1000000 + 10000 * k;
    w.Data(att, Pack(t) + Pack(1.0f) + Pack(0.0f) + Pack(0.0f) + Pack(0.0f));
    if (k % 5 == 0) {
      w.Data(vm, Pack(t + kPublishLagUs) + Pack(t) + Pack<uint32_t>(9) + Pack(0.2f) + Pack(0.0f) + Pack(0.4f) +
                     Pack<uint8_t>(1));
    }
  }
  auto r = ImportULog(w.bytes(), "lag.ulg");
  ASSERT_TRUE(r.ok()) << r.status().message();
  const FlightLog* mag = r->log.Stream("mag");
  ASSERT_NE(mag, nullptr);
  ASSERT_EQ(mag->rows(), 20u);
  for (size_t i = 0; i < mag->rows(); ++i) EXPECT_DOUBLE_EQ(mag->Column("t_s")[i], 1.0 + 0.05 * static_cast<double>(i));
  // The table holds a sample from its sample time on (row 5 is at 1.05 s, the second sample's time).
  EXPECT_DOUBLE_EQ(r->log.Column("mag_t_s")[5], 1.05);
  EXPECT_EQ(r->log.meta["compasses"][0]["time"].get<std::string>(), "timestamp_sample");
}

TEST(ULogStreams, GivenGpsFixes_WhenImported_ThenTheMetaHoldsTheFirst3dFixAsTheLocationAndNoDateWithoutUtc) {
  auto r = ImportULog(MultiRate(), "multi.ulg");
  ASSERT_TRUE(r.ok()) << r.status().message();
  const auto& meta = r->log.meta;
  ASSERT_TRUE(meta.contains("location"));  // the place of the Earth-field model (gap diagnose)
  EXPECT_NEAR(meta["location"]["lat_deg"].get<double>(), 47.0, 0.01);
  EXPECT_DOUBLE_EQ(meta["location"]["lon_deg"].get<double>(), 8.5);
  EXPECT_DOUBLE_EQ(meta["location"]["alt_m"].get<double>(), 500.0);
  EXPECT_FALSE(meta.contains("date_decimal_year"));  // this topic layout has no time_utc_usec
}

TEST(ULogStreams, GivenAUnixTime_WhenConvertedToADecimalYear_ThenItIsUtc) {
  EXPECT_NEAR(DecimalYearFromUnix(1577836800.0), 2020.0, 1e-9);  // 2020-01-01T00:00:00Z
  EXPECT_EQ(IsoUtcFromUnix(1577836800.0), "2020-01-01T00:00:00Z");
}

}  // namespace
}  // namespace hexsim::logs
