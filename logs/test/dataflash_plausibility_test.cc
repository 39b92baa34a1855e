// Damaged logs: implausible records are dropped and counted, damage never creates columns, heavy
// damage is refused (dataflash_plausibility.h).
#include "hexsim/logs/dataflash_plausibility.h"

#include <cmath>
#include <cstring>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "hexsim/logs/dataflash_import.h"
#include "support/dataflash_writer.h"

namespace hexsim::logs {
namespace {

using testing::DataFlashWriter;
using testing::RealLogBytes;

// The real log with `n` bytes at random places replaced by random values (fixed seed: the same
// damaged copy on every machine; std::mt19937_64 is fully specified by the standard).
std::string Damaged(size_t n, uint64_t seed) {
  std::string bytes = RealLogBytes();
  std::mt19937_64 rng(seed);
  for (size_t i = 0; i < n; ++i) {
    const size_t at = static_cast<size_t>(rng() % bytes.size());
    bytes[at] = static_cast<char>(rng() & 0xff);
  }
  return bytes;
}

std::set<std::string> Columns(const FlightLog& log) { return {log.columns().begin(), log.columns().end()}; }

const ImportResult& CleanImport() {
  static const ImportResult r = [] {
    auto i = ImportDataFlash(RealLogBytes(), "clean.bin");
    if (!i.ok()) throw std::runtime_error(i.status().message());
    return std::move(i).value();
  }();
  return r;
}

// A 3.3-layout log: ATT (centidegrees), a float-valued MAG layout, PARM.
DataFlashWriter SmallLog(int n_att, double roll_cdeg = 1234) {
  DataFlashWriter w;
  w.Fmt(130, "ATT", "IccccCCCC", "TimeMS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw");
  w.Fmt(132, "MAG", "Qffffff", "TimeUS,MagX,MagY,MagZ,MOfsX,MOfsY,MOfsZ");
  w.Fmt(133, "PARM", "QNf", "TimeUS,Name,Value");
  for (int i = 0; i < n_att; ++i) {
    w.Msg(130, "IccccCCCC", {1000.0 + 100 * i, 0, roll_cdeg, 0, -567, 0, 35900, 0, 0});
    w.Msg(132, "Qffffff", {1e6 + 1e5 * i, 200.0 + i % 3, -50, 400, 0, 0, 0});  // noise in the last digit
  }
  return w;
}

TEST(DataFlashPlausibility, GivenTheUndamagedRealLog_WhenImported_ThenNoRecordIsDropped) {
  // Given / When
  const ImportResult& r = CleanImport();
  // Then: the bounds are physical, so an intact log loses nothing to them.
  EXPECT_GT(r.records.checked, 30000u);
  EXPECT_EQ(r.records.type, 0u);
  EXPECT_EQ(r.records.range, 0u);
  EXPECT_EQ(r.records.time, 0u);
  EXPECT_EQ(DamagedRecordShare(r.damage, r.records, r.records_accepted), 0.0);
  EXPECT_EQ(r.log.meta["damage"]["records_dropped_range"], 0);
}

TEST(DataFlashPlausibility, Given2000RandomBytesChanged_WhenImported_ThenNoColumnIsAddedAndDamageIsCounted) {
  for (uint64_t seed : {19u, 20u, 21u}) {
    // Given
    const std::string bytes = Damaged(2000, seed);
    // When
    auto r = ImportDataFlash(bytes, "damaged.bin");
    // Then
    ASSERT_TRUE(r.ok()) << r.status().message();
    const std::set<std::string> clean = Columns(CleanImport().log), damaged = Columns(r->log);
    for (const auto& c : damaged) EXPECT_TRUE(clean.count(c)) << "seed " << seed << ": damage created column " << c;
    // ... nor streams, nor columns in them (the native-rate <log>.<stream>.csv tables).
    for (const char* name : {"imu", "imu2", "imu3", "rcou", "batt", "baro", "gps", "mag", "mag2", "mag3", "ekf", "ctun"}) {
      const FlightLog* d = r->log.Stream(name);
      if (d == nullptr) continue;
      const FlightLog* c = CleanImport().log.Stream(name);
      ASSERT_NE(c, nullptr) << "seed " << seed << ": damage created stream " << name;
      const std::set<std::string> cc = Columns(*c);
      for (const auto& col : Columns(*d)) EXPECT_TRUE(cc.count(col)) << name << ": damage created column " << col;
    }
    EXPECT_GT(r->records.range + r->records.type, 0u) << "seed " << seed;
    const double share = DamagedRecordShare(r->damage, r->records, r->records_accepted);
    EXPECT_GT(share, 0.0);
    EXPECT_LT(share, kMaxDamagedRecordShare);
    EXPECT_GT(r->log.rows(), CleanImport().log.rows() * 9 / 10);
    const std::string line = DamageSummaryLine("damaged.bin", r->damage, r->records, r->records_accepted);
    EXPECT_EQ(line.rfind("damaged.bin: damaged log: ", 0), 0u) << line;
    EXPECT_EQ(line.find('\n'), std::string::npos);
  }
}

TEST(DataFlashPlausibility, GivenTheDamagedLog_WhenInfoIsAsked_ThenItShowsTheDroppedCounts) {
  // Given
  const std::string bytes = Damaged(2000, 19);
  // When
  const std::string info = DataFlashInfo(bytes, "damaged.bin");
  const nlohmann::json j = DataFlashInfoJson(bytes, "damaged.bin");
  // Then
  EXPECT_NE(info.find("records_dropped_range="), std::string::npos) << info;
  EXPECT_NE(info.find("damaged_record_share="), std::string::npos) << info;
  EXPECT_GT(j["damage"]["records_dropped_range"].get<size_t>() + j["damage"]["records_dropped_type"].get<size_t>(), 0u);
}

TEST(DataFlashPlausibility, GivenARollOutsideItsDomain_WhenImported_ThenThatRecordAloneIsDroppedAsRange) {
  // Given: 20 good attitude records and one at roll 300 deg
  DataFlashWriter w = SmallLog(20);
  w.Msg(130, "IccccCCCC", {1000.0 + 100 * 20, 0, 30000, 0, -567, 0, 35900, 0, 0});
  // When
  auto r = ImportDataFlash(w.bytes(), "small.bin");
  // Then
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_EQ(r->log.rows(), 20u);
  EXPECT_EQ(r->records.range, 1u);
  EXPECT_EQ(r->records.by_message.at("ATT"), 1u);
}

TEST(DataFlashPlausibility, GivenFloatsAndNamesTheirFmtCannotMean_WhenImported_ThenDroppedAsType) {
  // Given: a NaN field value, a subnormal one, a parameter name with control bytes
  DataFlashWriter w = SmallLog(20);
  w.Msg(132, "Qffffff", {3e6, std::nan(""), -50, 400, 0, 0, 0});
  w.Msg(132, "Qffffff", {3.1e6, 1e-40, -50, 400, 0, 0, 0});
  w.Msg(133, "QNf", {3.2e6, 1}, {"COMPASS_\x01\x02"});
  w.Msg(133, "QNf", {3.3e6, 7}, {"COMPASS_USE"});
  // When
  auto r = ImportDataFlash(w.bytes(), "small.bin");
  // Then
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_EQ(r->records.type, 3u);
  EXPECT_EQ(r->records.by_message.at("MAG"), 2u);
  EXPECT_EQ(r->records.by_message.at("PARM"), 1u);
  EXPECT_EQ(r->log.meta["params"].size(), 1u) << r->log.meta["params"].dump();
}

// ArduPilot's "not available" value, AP_Logger::quiet_nanf() (bits 0x7FC04152), as the writer's double.
double ArduPilotNotAvailable() {
  const uint32_t bits = 0x7FC04152u;
  float f = 0;
  std::memcpy(&f, &bits, sizeof f);
  return static_cast<double>(f);
}

TEST(DataFlashPlausibility, GivenABatteryMonitorWithoutCurrent_WhenImported_ThenItsRecordsStayWithVoltageAndNoCurrent) {
  // Given: ArduCopter 4.x BAT records of a voltage-only monitor: Curr, CurrTot, EnrgTot are
  // ArduPilot's "not available" NaN in every record (a real 4.5.7 log: all 293 BAT records)
  DataFlashWriter w = SmallLog(20);
  w.Fmt(134, "BAT", "QBffffff", "TimeUS,Inst,Volt,VoltR,Curr,CurrTot,EnrgTot,Temp");
  const double na = ArduPilotNotAvailable();
  for (int i = 0; i < 20; ++i) w.Msg(134, "QBffffff", {1e6 + 1e5 * i, 0, 50.4, 50.4, na, na, na, 0});
  // When
  auto r = ImportDataFlash(w.bytes(), "voltage_only.bin");
  // Then: nothing is damage, the voltage is imported, and there is no current column at all
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_EQ(r->records.type, 0u);
  EXPECT_EQ(r->records.by_message.count("BAT"), 0u);
  EXPECT_TRUE(r->log.Has("voltage_V"));
  EXPECT_FALSE(r->log.Has("current_A"));
  const FlightLog* batt = r->log.Stream("batt");
  ASSERT_NE(batt, nullptr);
  EXPECT_TRUE(batt->Has("voltage_V"));
  EXPECT_FALSE(batt->Has("current_A"));
}

TEST(DataFlashPlausibility, GivenCurrentNotAvailableOnlyBeforeTheSensorsFirstReading_WhenImported_ThenTheReadingsStay) {
  // Given: the first 5 BAT records before the monitor's first current reading, then 15 readings
  DataFlashWriter w = SmallLog(20);
  w.Fmt(134, "BAT", "Qfff", "TimeUS,Volt,Curr,CurrTot");
  for (int i = 0; i < 20; ++i) {
    const double a = i < 5 ? ArduPilotNotAvailable() : 12.5;
    w.Msg(134, "Qfff", {1e6 + 1e5 * i, 16.0, a, a});
  }
  // When
  auto r = ImportDataFlash(w.bytes(), "late_current.bin");
  // Then
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_EQ(r->records.type, 0u);
  ASSERT_TRUE(r->log.Has("current_A"));
  const std::vector<double>& cur = r->log.Column("current_A");
  EXPECT_EQ(cur.back(), 12.5);
}

TEST(DataFlashPlausibility, GivenAFewNonZeroMotorOffsetsWithoutCompensation_WhenImported_ThenNoMotorColumns) {
  // Given: two of 22 MAG samples with motor offsets, no COMPASS_MOTCT in the log
  DataFlashWriter w = SmallLog(20);
  w.Msg(132, "Qffffff", {3e6, 200, -50, 400, 12, 0, 0});
  w.Msg(132, "Qffffff", {3.1e6, 200, -50, 400, 0, -7, 0});
  // When
  auto r = ImportDataFlash(w.bytes(), "small.bin");
  // Then
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_TRUE(r->log.Has("mag_x_uT"));
  EXPECT_FALSE(r->log.Has("mag_mot_x_uT"));
  // ... while compensation switched on (COMPASS_MOTCT 2: current) keeps them.
  DataFlashWriter on = SmallLog(20);
  on.Msg(133, "QNf", {0.5e6, 2}, {"COMPASS_MOTCT"});
  on.Msg(132, "Qffffff", {3e6, 200, -50, 400, 12, 0, 0});
  auto r2 = ImportDataFlash(on.bytes(), "small.bin");
  ASSERT_TRUE(r2.ok()) << r2.status().message();
  EXPECT_TRUE(r2->log.Has("mag_mot_x_uT"));
}

TEST(DataFlashPlausibility, GivenEveryAttitudeRecordDamaged_WhenImported_ThenBadInputSaysSo) {
  // Given: all 20 ATT records at roll 300 deg (the share test would refuse it too; MAG dilutes it)
  DataFlashWriter w = SmallLog(20, 30000);
  for (int i = 0; i < 200; ++i) w.Msg(132, "Qffffff", {5e6 + 1e4 * i, 200, -50, 400, 0, 0, 0});
  // When
  auto r = ImportDataFlash(w.bytes(), "noatt.bin");
  // Then
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kBadInput);
  EXPECT_NE(r.status().message().find("every attitude record is damaged"), std::string::npos)
      << r.status().message();
}

TEST(DataFlashPlausibility, GivenMoreThanAFifthOfTheRecordsDamaged_WhenImported_ThenRefusedWithTheShare) {
  // Given: a quarter of the MAG records far outside any compass's range
  DataFlashWriter w = SmallLog(100);
  for (int i = 0; i < 100; ++i) w.Msg(132, "Qffffff", {2e7 + 1e4 * i, 90000, -50, 400, 0, 0, 0});
  // When
  auto r = ImportDataFlash(w.bytes(), "bad.bin");
  // Then
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kBadInput);
  EXPECT_EQ(r.status().message().rfind("bad.bin: damage: 33 % of the records are damaged", 0), 0u)
      << r.status().message();
}

TEST(DataFlashPlausibility, GivenUnusedRcouChannelsHoldingGarbage_WhenImported_ThenRecordsStayAndOnlyThoseChannelsAreAbsent) {
  // Given: RCOU with four motor channels in range and four unused ones holding constant values no
  // servo output can have (as a PXF cape logs them), then one record with every channel implausible
  DataFlashWriter w = SmallLog(20);
  w.Fmt(134, "RCOU", "Ihhhhhhhh", "TimeMS,Ch1,Ch2,Ch3,Ch4,Ch5,Ch6,Ch7,Ch8");
  for (int i = 0; i < 20; ++i) {
    w.Msg(134, "Ihhhhhhhh", {1000.0 + 100 * i, 1500, 1500, 1500, 1500, -8047, -27794, -30415, -21887});
  }
  w.Msg(134, "Ihhhhhhhh", {1000.0 + 100 * 20, -1, -2, -3, -4, -8047, -27794, -30415, -21887});
  // When
  auto r = ImportDataFlash(w.bytes(), "small.bin");
  // Then: the frame is unknown, so the leading plausible channels are the motors; the garbage
  // channels are absent, and only the all-implausible record is dropped
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_EQ(r->records.range, 1u);
  EXPECT_TRUE(r->log.Has("motor_4_u"));
  EXPECT_FALSE(r->log.Has("motor_5_u"));
  EXPECT_NEAR(r->log.Column("motor_1_u")[10], 0.5, 1e-9);  // 1500 us in the default 1000..2000
  const FlightLog* rcou = r->log.Stream("rcou");
  ASSERT_NE(rcou, nullptr);
  EXPECT_TRUE(std::isnan(rcou->Column("pwm_5_us")[3]));
  EXPECT_DOUBLE_EQ(rcou->Column("pwm_4_us")[3], 1500.0);
}

TEST(DataFlashPlausibility, GivenALogStartingWithEvArmedBeforeAnyTime_WhenImported_ThenItIsArmedFromTheStart) {
  // Given: a log that starts at arming (EV ARMED first, an EV without a time field, as 3.x writes it)
  DataFlashWriter w;
  w.Fmt(135, "EV", "B", "Id");
  w.Msg(135, "B", {10});
  DataFlashWriter rest = SmallLog(40);
  w.Raw(rest.bytes());
  // When
  auto r = ImportDataFlash(w.bytes(), "small.bin");
  // Then
  ASSERT_TRUE(r.ok()) << r.status().message();
  ASSERT_TRUE(r->log.Has("armed"));
  for (const double a : r->log.Column("armed")) EXPECT_EQ(a, 1.0);
}

}  // namespace
}  // namespace hexsim::logs
