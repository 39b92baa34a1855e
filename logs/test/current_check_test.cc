// Units from the format chars, and the data-level check of the imported current (current_check.h),
// on DataFlash and ULog byte streams the tests write themselves.
#include "hexsim/logs/current_check.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hexsim/common/atomic_file.h"
#include "hexsim/logs/dataflash_import.h"
#include "hexsim/logs/read_log.h"
#include "hexsim/logs/ulog_import.h"
#include "support/dataflash_writer.h"
#include "support/ulog_writer.h"

namespace hexsim::logs {
namespace {

using testing::DataFlashWriter;

enum class CurrForm { kFloat34, kIntegerHundredths33 };

// 20 s of a hovering quad (FRAME_CLASS 1) at 10 Hz: ATT, RCOU at 1500 µs (output 0.5), and CURR
// with `amps` and `volts` as ArduCopter 3.4 logs them (Qfff: floats in V, A, mAh) or as 3.3 does
// (IhhhHfh: int16 hundredths). `params` adds PARM records.
DataFlashWriter HoverLog(CurrForm form, double amps, double volts,
                         const std::vector<std::pair<std::string, double>>& params = {}) {
  DataFlashWriter w;
  w.Fmt(129, "PARM", "QNf", "TimeUS,Name,Value");
  w.Fmt(130, "ATT", "QccccCCCC", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw");
  w.Fmt(131, "RCOU", "QHHHHHHHH", "TimeUS,C1,C2,C3,C4,C5,C6,C7,C8");
  if (form == CurrForm::kFloat34) {
    w.Fmt(132, "CURR", "Qfff", "TimeUS,Volt,Curr,CurrTot");
  } else {
    w.Fmt(132, "CURR", "QhhhHfh", "TimeUS,Throttle,Volt,Curr,Vcc,CurrTot,Volt2");
  }
  w.Msg(129, "QNf", {1000, 1}, {"FRAME_CLASS"});
  for (const auto& [name, value] : params) w.Msg(129, "QNf", {1000, value}, {name});
  for (int i = 0; i < 200; ++i) {
    const double t_us = 1e6 + 1e5 * i;
    w.Msg(130, "QccccCCCC", {t_us, 0, 100, 0, -50, 0, 9000, 0, 0});
    w.Msg(131, "QHHHHHHHH", {t_us, 1500, 1500, 1500, 1500, 1100, 1100, 0, 0});
    if (form == CurrForm::kFloat34) {
      w.Msg(132, "Qfff", {t_us, volts, amps, 0.1 * i});
    } else {
      w.Msg(132, "QhhhHfh", {t_us, 500, std::round(volts * 100), std::round(amps * 100), 5000, 0.1 * i, 0});
    }
  }
  return w;
}

ImportResult MustImport(const std::string& bytes) {
  auto r = ImportDataFlash(bytes, "hover.bin");
  if (!r.ok()) throw std::runtime_error(r.status().message());
  return std::move(r).value();
}

TEST(CurrentUnits, GivenCurrLoggedAsFloats_WhenImported_ThenAmpsAndVoltsAreTheLoggedValues) {
  const ImportResult r = MustImport(HoverLog(CurrForm::kFloat34, 14.0, 15.2).bytes());
  const FlightLog& log = r.log;
  // Float fields are stored in their unit: a table entry for int16 hundredths must not divide them.
  EXPECT_NEAR(log.Column("current_A")[50], 14.0, 1e-5);
  EXPECT_NEAR(log.Column("voltage_V")[50], 15.2, 1e-5);
  EXPECT_TRUE(log.meta["current_usable"].get<bool>());
  EXPECT_EQ(log.meta["current_unusable_why"], "");
}

TEST(CurrentUnits, GivenCurrLoggedAsIntegerHundredths_WhenImported_ThenTheTableScaleGivesAmps) {
  const ImportResult r = MustImport(HoverLog(CurrForm::kIntegerHundredths33, 14.0, 15.2).bytes());
  EXPECT_NEAR(r.log.Column("current_A")[50], 14.0, 1e-9);
  EXPECT_NEAR(r.log.Column("voltage_V")[50], 15.2, 1e-9);
  EXPECT_TRUE(r.log.meta["current_usable"].get<bool>());
}

TEST(CurrentUnits, GivenFmtuMultipliersOnIntegerAndFloatFields_WhenDecoded_ThenOnlyTheIntegerIsScaled) {
  DataFlashWriter w;
  w.Fmt(150, "MULT", "Qbd", "TimeUS,Id,Mult");
  w.Fmt(152, "FMTU", "QBNN", "TimeUS,FmtType,UnitIds,MultIds");
  w.Fmt(153, "BAT", "Qhf", "TimeUS,VoltI,Curr");
  w.Msg(150, "Qbd", {0, 'B', 1e-2});
  w.Msg(152, "QBNN", {0, 153}, {"svA", "FBB"});  // a MULT beside a float says nothing about its value
  w.Msg(153, "Qhf", {1e6, 1520, 14.5});
  DataFlashReader reader(w.bytes());
  DataFlashMessage m;
  bool seen = false;
  while (reader.Next(&m)) {
    if (m.name() != "BAT") continue;
    seen = true;
    EXPECT_NEAR(m.Get("VoltI"), 15.2, 1e-12);
    EXPECT_NEAR(m.Get("Curr"), 14.5, 1e-6);
  }
  EXPECT_TRUE(seen);
}

TEST(CurrentUnits, GivenAHalfPrecisionField_WhenDecoded_ThenItIsTheIeeeBinary16Value) {
  DataFlashWriter w;
  w.Fmt(140, "HALF", "QHHH", "TimeUS,A,B,C");  // written as raw uint16, then read as 'g'
  w.Msg(140, "QHHH", {1e6, 0x3C00, 0xC500, 0x0001});
  std::string bytes = w.bytes();
  const size_t fmt_at = bytes.find("QHHH");
  bytes.replace(fmt_at, 4, "Qggg");
  DataFlashReader reader(bytes);
  DataFlashMessage m;
  bool seen = false;
  while (reader.Next(&m)) {
    if (m.name() != "HALF") continue;
    seen = true;
    EXPECT_DOUBLE_EQ(m.Get("A"), 1.0);
    EXPECT_DOUBLE_EQ(m.Get("B"), -5.0);
    EXPECT_DOUBLE_EQ(m.Get("C"), std::ldexp(1.0, -24));  // the smallest subnormal
  }
  EXPECT_TRUE(seen);
}

// What the importer made of a 3.4 log before the format char decided (÷100): a hovering quad at
// 0.14 A and 0.15 V. The check flags it, and the flag survives the CSV + meta round trip.
TEST(CurrentCheck, GivenAHoveringQuadAtATenthOfAnAmp_WhenImported_ThenTheCurrentIsUnusableAndSaysWhy) {
  const ImportResult r = MustImport(HoverLog(CurrForm::kFloat34, 0.14, 0.152).bytes());
  const CurrentSensorCheck c = CurrentSensorOf(r.log);
  EXPECT_FALSE(c.usable);
  EXPECT_TRUE(c.checked);
  EXPECT_EQ(c.motors, 4);
  EXPECT_EQ(c.why.rfind("current sensor unusable: units or no power monitor", 0), 0u) << c.why;
  EXPECT_NE(c.why.find("0.14 A"), std::string::npos) << c.why;
  EXPECT_FALSE(r.log.meta["current_usable"].get<bool>());

  const std::string dir = ::testing::TempDir() + "/current_check_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  ASSERT_TRUE(WriteImport(r, dir + "/l.csv").ok());
  auto back = ReadFlightLog(dir + "/l.csv");
  ASSERT_TRUE(back.ok()) << back.status().message();
  const CurrentSensorCheck b = CurrentSensorOf(*back);
  EXPECT_FALSE(b.usable);
  EXPECT_EQ(b.why, c.why);
  std::filesystem::remove_all(dir);
}

TEST(CurrentCheck, GivenTheCellCountFromTheParameters_WhenThePackReadsTwoVoltsPerCell_ThenItIsUnusable) {
  // 8 V is a plausible 2S pack, but MOT_BAT_VOLT_MAX 16.8 says 4 cells: 2.0 V per cell.
  const ImportResult four = MustImport(HoverLog(CurrForm::kFloat34, 14.0, 8.0, {{"MOT_BAT_VOLT_MAX", 16.8}}).bytes());
  const CurrentSensorCheck c = CurrentSensorOf(four.log);
  EXPECT_FALSE(c.usable);
  EXPECT_EQ(c.cells, 4);
  EXPECT_NE(c.why.find("per cell"), std::string::npos) << c.why;
  const ImportResult unknown = MustImport(HoverLog(CurrForm::kFloat34, 14.0, 8.0).bytes());
  EXPECT_TRUE(CurrentSensorOf(unknown.log).usable) << CurrentSensorOf(unknown.log).why;
}

TEST(CurrentCheck, GivenAFlightWithoutAMotorCount_WhenPrinted_ThenTheLineSaysTheCountIsUnknownNotZeroMotors) {
  // Given: a flight known from control_u alone (ArduCopter 3.1: no RCOU, no frame in the log)
  FlightLog log;
  for (int i = 0; i < 50; ++i) {
    log.AppendRow();
    log.Set("t_s", 0.1 * i);
    log.Set("current_A", 27.4);
    log.Set("voltage_V", 15.0);
    log.Set("control_u", 550.0);
  }
  // When
  const CurrentSensorCheck c = CheckCurrentSensor(log);
  const std::string line = CurrentCheckLine(c);
  // Then
  EXPECT_TRUE(c.usable) << c.why;
  EXPECT_TRUE(c.checked);
  EXPECT_EQ(c.motors, 0);
  EXPECT_EQ(line.find("0 motors"), std::string::npos) << line;
  EXPECT_NE(line.find("motor count unknown"), std::string::npos) << line;
}

TEST(CurrentCheck, GivenMotorsAtFlightOutputButNoClimb_WhenChecked_ThenTheCurrentIsNotJudgedAsAFlightCurrent) {
  // Given: 30 s at motor output 0.49 and 2.6 A on a 12S pack, the barometer within ±0.05 m (a
  // props-off run of a 4.7.0-dev heavy quad), and the same with a climb to 5 m
  auto make = [](double climb_m) {
    FlightLog log;
    for (int i = 0; i < 300; ++i) {
      log.AppendRow();
      log.Set("t_s", 0.1 * i);
      log.Set("current_A", 2.6);
      log.Set("voltage_V", 51.2);
      log.Set("motor_1_u", 0.49);
      log.Set("baro_alt_m", 0.05 * std::sin(0.7 * i) + climb_m * std::min(1.0, i / 100.0));
    }
    return log;
  };
  // When
  const CurrentSensorCheck ground = CheckCurrentSensor(make(0.0));
  const CurrentSensorCheck flown = CheckCurrentSensor(make(5.0));
  // Then
  EXPECT_FALSE(ground.checked);
  EXPECT_EQ(ground.flight_rows, 0u);
  EXPECT_NE(ground.note.find("a run on the ground"), std::string::npos) << ground.note;
  EXPECT_TRUE(flown.checked);
  EXPECT_EQ(flown.flight_rows, 300u);
  // the ground run's current is unverified and no flight current: unusable, with the reason
  EXPECT_FALSE(ground.usable);
  EXPECT_EQ(ground.why.rfind("current sensor unusable: not checked in flight: ", 0), 0u) << ground.why;
  EXPECT_NE(ground.why.find("a run on the ground"), std::string::npos) << ground.why;
  EXPECT_NE(CurrentCheckLine(ground).find("unusable"), std::string::npos) << CurrentCheckLine(ground);
  EXPECT_TRUE(flown.usable) << flown.why;
}

TEST(CurrentCheck, GivenMotorsThatNeverReachFlightOutput_WhenChecked_ThenTheCurrentIsUnusableButALogWithoutThrottleIsNotJudged) {
  // Given: 30 s armed at motor output 0.1 (idle: never carried the vehicle), 1.2 A, 16 V; and the
  // same rows with no motor outputs and no control_u (the log cannot tell when it flew)
  auto make = [](bool outputs) {
    FlightLog log;
    for (int i = 0; i < 300; ++i) {
      log.AppendRow();
      log.Set("t_s", 0.1 * i);
      log.Set("current_A", 1.2);
      log.Set("voltage_V", 16.0);
      log.Set("armed", 1.0);
      if (outputs) {
        for (int m = 1; m <= 4; ++m) log.Set("motor_" + std::to_string(m) + "_u", 0.1);
      }
    }
    return log;
  };
  // When
  const CurrentSensorCheck idle = CheckCurrentSensor(make(true));
  const CurrentSensorCheck blind = CheckCurrentSensor(make(false));
  // Then
  EXPECT_FALSE(idle.usable);
  EXPECT_EQ(idle.why.rfind("current sensor unusable: not checked in flight: no flight rows", 0), 0u) << idle.why;
  EXPECT_TRUE(blind.usable) << blind.why;
  EXPECT_FALSE(blind.checked);
  EXPECT_NE(blind.note.find("no flight rows"), std::string::npos) << blind.note;
}

TEST(CurrentCheck, GivenALogOfOneMotor_WhenTheCurrentIsJudged_ThenTheLineSaysTheLogsCountBesideTheThree) {
  // A PX4 1.17 log with CA_ROTOR_COUNT 1 was judged "over 3 motors", the log's own count unsaid
  FlightLog log;
  log.meta["motor_count"] = 1;
  for (int i = 0; i < 50; ++i) {
    log.AppendRow();
    log.Set("t_s", 0.1 * i);
    log.Set("current_A", 0.0);
    log.Set("voltage_V", 15.0);
    log.Set("motor_1_u", 0.5);
  }
  const CurrentSensorCheck c = CheckCurrentSensor(log);
  EXPECT_FALSE(c.usable);
  EXPECT_NE(c.why.find("over 3 motors (the log says 1: a multirotor has at least 3)"), std::string::npos) << c.why;
}

TEST(CurrentCheck, GivenACurrentColumnWithoutANumber_WhenChecked_ThenTheLogHasNoCurrent) {
  FlightLog log;
  for (int i = 0; i < 50; ++i) {
    log.AppendRow();
    log.Set("t_s", 0.1 * i);
    log.Set("current_A", std::nan(""));
    log.Set("voltage_V", 15.0);
    log.Set("motor_1_u", 0.5);
  }
  const CurrentSensorCheck c = CheckCurrentSensor(log);
  EXPECT_FALSE(c.usable);
  EXPECT_NE(c.why.find("the log has no current"), std::string::npos) << c.why;
}

TEST(DamageLines, GivenALogCutInsideItsLastMessage_WhenImported_ThenOneTruncationLineAndACleanLogSaysNothing) {
  const std::string clean = HoverLog(CurrForm::kFloat34, 14.0, 15.2).bytes();
  const ImportResult ok = MustImport(clean);
  EXPECT_TRUE(DamageLines("hover.bin", ok.damage, ok.records, ok.records_accepted).empty());
  const ImportResult cut = MustImport(clean.substr(0, clean.size() - 7));
  const auto lines = DamageLines("hover.bin", cut.damage, cut.records, cut.records_accepted);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0].rfind("hover.bin: truncated: ", 0), 0u) << lines[0];
}

// A PX4 flight at hover output with the battery's current and voltage as given.
std::string PxFlight(float amps, float volts) {
  using testing::Pack;
  testing::ULogWriter w;
  w.Param("CA_ROTOR_COUNT", 4.0f);
  w.Param("BAT1_N_CELLS", 4.0f);
  w.Format("vehicle_attitude:uint64_t timestamp;float[4] q;");
  w.Format("battery_status:uint64_t timestamp;float voltage_v;float current_a;");
  w.Format("actuator_motors:uint64_t timestamp;float[4] control;");
  const uint16_t att = w.Subscribe("vehicle_attitude", 0);
  const uint16_t bat = w.Subscribe("battery_status", 0);
  const uint16_t mot = w.Subscribe("actuator_motors", 0);
  for (int k = 0; k < 100; ++k) {
    const uint64_t t_us = 1000000 + 100000ull * static_cast<uint64_t>(k);
    w.Data(att, Pack(t_us) + Pack(1.0f) + Pack(0.0f) + Pack(0.0f) + Pack(0.0f));
    w.Data(bat, Pack(t_us) + Pack(volts) + Pack(amps));
    w.Data(mot, Pack(t_us) + Pack(0.5f) + Pack(0.5f) + Pack(0.5f) + Pack(0.5f));
  }
  return w.bytes();
}

TEST(CurrentCheck, GivenAULogWithoutAPowerMonitor_WhenImported_ThenTheCurrentIsUnusableAndATruncatedFileSaysSo) {
  auto good = ImportULog(PxFlight(12.0f, 15.8f), "px.ulg");
  ASSERT_TRUE(good.ok()) << good.status().message();
  EXPECT_TRUE(good->log.meta["current_usable"].get<bool>()) << good->log.meta["current_unusable_why"];
  EXPECT_TRUE(good->warnings.empty());
  auto none = ImportULog(PxFlight(0.0f, 15.8f), "px.ulg");
  ASSERT_TRUE(none.ok()) << none.status().message();
  EXPECT_FALSE(CurrentSensorOf(none->log).usable);
  auto low = ImportULog(PxFlight(12.0f, 7.0f), "px.ulg");  // BAT1_N_CELLS 4: 1.75 V per cell
  ASSERT_TRUE(low.ok()) << low.status().message();
  EXPECT_NE(CurrentSensorOf(low->log).why.find("BAT1_N_CELLS"), std::string::npos) << CurrentSensorOf(low->log).why;
  const std::string bytes = PxFlight(12.0f, 15.8f);
  auto cut = ImportULog(bytes.substr(0, bytes.size() - 5), "px.ulg");
  ASSERT_TRUE(cut.ok()) << cut.status().message();
  ASSERT_EQ(cut->warnings.size(), 1u);
  EXPECT_NE(cut->warnings[0].find("truncated"), std::string::npos) << cut->warnings[0];
}

// gap and identify take a .bin or .ulg as they take a FlightLog CSV (before: "column name has control
// character 0x00").
TEST(ReadAnyFlightLog, GivenADataFlashOrULogFile_WhenRead_ThenItIsImportedInMemoryAndSaysSo) {
  const std::string dir = ::testing::TempDir() + "/read_any_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  ASSERT_TRUE(WriteFileAtomic(dir + "/hover.bin", HoverLog(CurrForm::kFloat34, 0.14, 0.152).bytes()).ok());
  ASSERT_TRUE(WriteFileAtomic(dir + "/px.ulg", PxFlight(12.0f, 15.8f)).ok());
  std::vector<std::string> notes;
  auto bin = ReadAnyFlightLog(dir + "/hover.bin", &notes);
  ASSERT_TRUE(bin.ok()) << bin.status().message();
  EXPECT_EQ(bin->rows(), 200u);
  EXPECT_EQ(bin->meta["source"], "hover.bin");
  ASSERT_EQ(notes.size(), 2u);
  EXPECT_NE(notes[0].find("imported in memory"), std::string::npos) << notes[0];
  EXPECT_NE(notes[1].find("current sensor unusable"), std::string::npos) << notes[1];
  notes.clear();
  auto ulg = ReadAnyFlightLog(dir + "/px.ulg", &notes);
  ASSERT_TRUE(ulg.ok()) << ulg.status().message();
  EXPECT_EQ(ulg->rows(), 100u);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("PX4 ULog, imported in memory"), std::string::npos) << notes[0];
  ASSERT_TRUE(WriteFlightLog(*bin, dir + "/hover.csv").ok());
  auto csv = ReadAnyFlightLog(dir + "/hover.csv");
  ASSERT_TRUE(csv.ok()) << csv.status().message();
  EXPECT_EQ(csv->rows(), 200u);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace hexsim::logs
