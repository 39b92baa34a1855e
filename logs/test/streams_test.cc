// Native-rate streams of an imported DataFlash log (CONTRACTS, real data: `<log>.<stream>.csv`).
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "hexsim/common/atomic_file.h"
#include "hexsim/logs/dataflash_import.h"
#include "support/dataflash_writer.h"

namespace hexsim::logs {
namespace {

using testing::DataFlashWriter;
using testing::RealLogBytes;

const ImportResult& RealImport() {
  static const ImportResult result = [] {
    auto r = ImportDataFlash(RealLogBytes(), "ardupilot_copter_log171.bin");
    if (!r.ok()) throw std::runtime_error(r.status().message());
    return std::move(r).value();
  }();
  return result;
}

double MedianRate_hz(const FlightLog& s) {
  const auto& t = s.Column("t_s");
  std::vector<double> dt;
  for (size_t i = 1; i < t.size(); ++i) dt.push_back(t[i] - t[i - 1]);
  std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
  return 1.0 / dt[dt.size() / 2];
}

// IMU at 200 Hz and ATT at 10 Hz for 2 s, one IMU time stamp damaged (a spike far in the future).
std::string FastImuLog() {
  DataFlashWriter w;
  w.Fmt(130, "ATT", "QccccCCCC", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw");
  w.Fmt(131, "IMU", "QffffffIIf", "TimeUS,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,ErrG,ErrA,Temp");
  for (int i = 0; i < 400; ++i) {
    const double t_us = 1e6 + 5000.0 * i;
    if (i % 20 == 0) w.Msg(130, "QccccCCCC", {t_us, 0, 0, 0, 0, 0, 0, 0, 0});
    const double stamp = i == 123 ? 9e9 : t_us;
    w.Msg(131, "QffffffIIf", {stamp, 0.01 * i, 0, 0, 0, 0, -9.8, 0, 0, 30});
  }
  return w.bytes();
}

TEST(Streams, GivenImuAt200HzAndAttAt10Hz_WhenImported_ThenTheImuStreamKeepsEverySampleAndDropsTheDamagedStamp) {
  auto r = ImportDataFlash(FastImuLog(), "fast.bin");
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_EQ(r->log.rows(), 20u);  // the single table: one row per ATT sample, as before
  const FlightLog* imu = r->log.Stream("imu");
  ASSERT_NE(imu, nullptr);
  EXPECT_EQ(imu->rows(), 399u);  // 400 samples, the spike dropped
  EXPECT_NEAR(MedianRate_hz(*imu), 200.0, 1e-6);
  EXPECT_EQ(r->log.meta["damage"]["stream_samples_dropped"], 1);
  // Values are the samples themselves, not resampled: sample 124 carries gyro_x = 1.24.
  EXPECT_NEAR(imu->Column("gyro_x_radps")[123], 1.24, 1e-6);
  EXPECT_EQ(r->log.Stream("rcou"), nullptr);  // no RCOU in this log: no stream
}

TEST(Streams, GivenTheRealLog_WhenImported_ThenEachSensorKeepsItsOwnRate) {
  const FlightLog& log = RealImport().log;
  ASSERT_NE(log.Stream("imu"), nullptr);
  // ArduCopter 3.3 logs IMU at ~50 Hz, ATT at 10 Hz: the stream has ~5x the rows of the table.
  EXPECT_NEAR(MedianRate_hz(*log.Stream("imu")), 50.0, 5.0);
  EXPECT_GT(log.Stream("imu")->rows(), 4 * log.rows());
  for (const char* s : {"rcou", "batt", "baro", "gps", "mag", "mag2", "mag3", "ekf", "ctun"}) {
    const FlightLog* st = log.Stream(s);
    ASSERT_NE(st, nullptr) << s;
    const auto& t = st->Column("t_s");
    EXPECT_TRUE(std::is_sorted(t.begin(), t.end())) << s;
    EXPECT_GT(st->rows(), 100u) << s;
  }
  const FlightLog& rcou = *log.Stream("rcou");
  EXPECT_TRUE(rcou.Has("motor_4_u"));
  EXPECT_FALSE(rcou.Has("motor_5_u"));  // a quad: four motors, the other outputs as pwm_j_us only
  EXPECT_TRUE(rcou.Has("pwm_4_us"));    // every output channel keeps its PWM
  // The table's held IMU sample is one of the stream's samples (same value at the held time).
  const auto& imu_t = log.Stream("imu")->Column("t_s");
  const auto& row_imu_t = log.Column("imu_t_s");
  const size_t r = log.rows() / 2;
  const auto it = std::lower_bound(imu_t.begin(), imu_t.end(), row_imu_t[r]);
  ASSERT_NE(it, imu_t.end());
  const size_t k = static_cast<size_t>(it - imu_t.begin());
  EXPECT_EQ(log.Stream("imu")->Column("gyro_y_radps")[k], log.Column("gyro_y_radps")[r]);
}

TEST(Streams, GivenAnImportWithStreams_WhenWrittenAndReadBack_ThenStreamsComeBackFromTheirOwnFiles) {
  // Per process: several checkouts may run this test at once.
  const std::string dir = ::testing::TempDir() + "/hexsim_streams_test_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/log.csv";
  ASSERT_TRUE(WriteImport(RealImport(), path).ok());
  EXPECT_TRUE(std::filesystem::is_regular_file(dir + "/log.imu.csv"));
  auto back = ReadFlightLog(path);
  ASSERT_TRUE(back.ok()) << back.status().message();
  EXPECT_EQ(back->columns(), RealImport().log.columns());  // the single table is unchanged
  auto names = back->stream_names(), expected = RealImport().log.stream_names();
  std::sort(names.begin(), names.end());
  std::sort(expected.begin(), expected.end());
  ASSERT_EQ(names, expected);
  const FlightLog& a = *RealImport().log.Stream("batt");
  const FlightLog& b = *back->Stream("batt");
  ASSERT_EQ(a.rows(), b.rows());
  EXPECT_EQ(a.Column("voltage_V")[a.rows() / 2], b.Column("voltage_V")[b.rows() / 2]);
  EXPECT_EQ(back->meta["streams"]["imu"]["file"], "log.imu.csv");
  // A stream read on its own.
  auto imu = ReadStream(path, "imu");
  ASSERT_TRUE(imu.ok());
  EXPECT_EQ(imu->rows(), RealImport().log.Stream("imu")->rows());
  // A meta naming a stream outside the directory is bad input, not a read elsewhere.
  nlohmann::json meta = back->meta;
  meta["streams"]["../x"] = {{"file", "x.csv"}};
  ASSERT_TRUE(WriteFileAtomic(dir + "/log.meta.json", meta.dump()).ok());
  auto bad = ReadFlightLog(path);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("streams"), std::string::npos);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace hexsim::logs

namespace hexsim::logs {
namespace {

TEST(Streams, GivenATableWithoutStreams_WhenAStreamIsAskedAtItsOwnRate_ThenTheDistinctHeldSamplesComeBack) {
  // Rows at 10 Hz; the battery sampled at 5 Hz (each sample held over two rows), none before 0.2 s.
  FlightLog log;
  for (int r = 0; r < 10; ++r) {
    log.AppendRow();
    log.Set("t_s", 0.1 * r);
    if (r >= 2) {
      const int held = r / 2;  // the battery sample changes every second row
      log.Set("batt_t_s", 0.2 * held);
      log.Set("voltage_V", 16.0 - 0.1 * held);
    }
    log.Set("gyro_x_radps", 0.01 * r);  // no imu_t_s: every row is a sample
  }
  bool from_table = false;
  const FlightLog batt = StreamAtOwnRate(log, "batt", &from_table);
  EXPECT_TRUE(from_table);
  ASSERT_EQ(batt.rows(), 4u);
  EXPECT_DOUBLE_EQ(batt.Column("t_s")[1], 0.4);
  EXPECT_DOUBLE_EQ(batt.Column("voltage_V")[1], 15.8);
  EXPECT_FALSE(batt.Has("current_A"));  // the table has no current column
  EXPECT_EQ(StreamAtOwnRate(log, "imu").rows(), 10u);
  EXPECT_EQ(StreamAtOwnRate(log, "rcou").rows(), 0u);
}

TEST(Streams, GivenTheRealImport_WhenAStreamIsAskedAtItsOwnRate_ThenTheNativeStreamIsReturned) {
  auto r = ImportDataFlash(testing::RealLogBytes(), "log171.bin");
  ASSERT_TRUE(r.ok());
  bool from_table = true;
  const FlightLog imu = StreamAtOwnRate(r->log, "imu", &from_table);
  EXPECT_FALSE(from_table);
  EXPECT_EQ(imu.rows(), r->log.Stream("imu")->rows());
}

}  // namespace
}  // namespace hexsim::logs
