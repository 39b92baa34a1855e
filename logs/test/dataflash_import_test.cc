#include "hexsim/logs/dataflash_import.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "hexsim/common/rotation.h"
#include "hexsim/logs/mag_input.h"
#include "support/dataflash_writer.h"

namespace hexsim::logs {
namespace {

using testing::RealLogBytes;

const ImportResult& RealImport() {
  static const ImportResult result = [] {
    auto r = ImportDataFlash(RealLogBytes(), "ardupilot_copter_log171.bin");
    if (!r.ok()) throw std::runtime_error(r.status().message());
    return std::move(r).value();
  }();
  return result;
}

double Quantile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(p * static_cast<double>(v.size() - 1))];
}

std::vector<double> FieldMagnitudes(const FlightLog& log, const std::string& prefix) {
  std::vector<double> f;
  const auto &x = log.Column(prefix + "_x_uT"), &y = log.Column(prefix + "_y_uT"), &z = log.Column(prefix + "_z_uT");
  for (size_t r = 0; r < log.rows(); ++r) {
    if (std::isfinite(x[r])) f.push_back(std::sqrt(x[r] * x[r] + y[r] * y[r] + z[r] * z[r]));
  }
  return f;
}

TEST(DataFlashImport, GivenTheRealLog_WhenImported_ThenOneRowPerAttSampleOverAbout243Seconds) {
  const FlightLog& log = RealImport().log;
  EXPECT_EQ(log.rows(), 2383u);  // ATT messages in the file
  const auto& t = log.Column("t_s");
  EXPECT_NEAR(t.back() - t.front(), 243.0, 1.0);
  EXPECT_NEAR(log.meta["row_rate_hz"].get<double>(), 10.0, 0.2);  // ATT logged at 10 Hz in 3.3
  EXPECT_EQ(log.meta["format"], "ardupilot-dataflash");
  EXPECT_EQ(log.meta["firmware"], "APM:Copter V3.3-dev (ae3192b8)");
  EXPECT_EQ(log.meta["vehicle_type"], "copter");
  EXPECT_EQ(log.meta["motor_count"], 4);  // "Frame: QUAD", FRAME 1 (X)
  EXPECT_EQ(RealImport().damage.skipped_bytes, 0u);
  for (const char* c : {"q_w", "gyro_x_radps", "accel_z_mps2", "mag_x_uT", "mag2_x_uT", "mag3_x_uT", "current_A",
                        "voltage_V", "control_u", "motor_1_u", "motor_4_u", "gps_N_m", "gps_vel_D_mps", "baro_alt_m",
                        "pos_N_m", "est_pos_N_m", "yaw_true_deg", "mode", "mag_t_s", "gps_t_s", "baro_t_s"}) {
    EXPECT_TRUE(log.Has(c)) << c;
  }
  EXPECT_FALSE(log.Has("motor_5_u"));
}

TEST(DataFlashImport, GivenTheRealLog_WhenImported_ThenQuaternionsAreUnitAndContinuousUntilTheFlipAtTheEnd) {
  const FlightLog& log = RealImport().log;
  const auto &t = log.Column("t_s"), &w = log.Column("q_w"), &x = log.Column("q_x"), &y = log.Column("q_y"),
             &z = log.Column("q_z");
  double max_step_deg = 0.0, max_step_end_deg = 0.0;
  for (size_t r = 0; r < log.rows(); ++r) {
    ASSERT_NEAR(w[r] * w[r] + x[r] * x[r] + y[r] * y[r] + z[r] * z[r], 1.0, 1e-12);
    ASSERT_TRUE(std::isfinite(log.Column("yaw_true_deg")[r]));
    ASSERT_GT(log.Column("yaw_true_deg")[r], -180.0);
    ASSERT_LE(log.Column("yaw_true_deg")[r], 180.0);
    if (r == 0) continue;
    const double dot = w[r] * w[r - 1] + x[r] * x[r - 1] + y[r] * y[r - 1] + z[r] * z[r - 1];
    EXPECT_GE(dot, 0.0);  // sign kept continuous
    const double step = 2.0 * std::acos(std::min(1.0, std::fabs(dot))) * kRadToDeg;
    (t[r] < 239.0 ? max_step_deg : max_step_end_deg) = std::max(t[r] < 239.0 ? max_step_deg : max_step_end_deg, step);
  }
  // In flight, 0.1 s rows: a multirotor's attitude rates stay below ~400 deg/s.
  EXPECT_LT(max_step_deg, 40.0);
  // The log ends with the vehicle rolled over (ATT Roll -181 deg in the last sample).
  EXPECT_GT(max_step_end_deg, 90.0);
}

TEST(DataFlashImport, GivenTheExternalCompass_WhenRotatedToNedByQ_ThenItPointsAlongCanberrasField) {
  // Physics check of the quaternion convention (body FRD -> NED): the external, calibrated
  // compass rotated by q must show the local Earth field. WMM2015 at 35.36 S 149.17 E, late 2015:
  // declination about +12 deg, inclination about -66 deg (field points up in the south).
  const FlightLog& log = RealImport().log;
  std::vector<double> dec, inc;
  for (size_t r = 0; r < log.rows(); ++r) {
    if (log.Column("t_s")[r] > 239.0) break;  // before the roll-over
    const Eigen::Quaterniond q(log.Column("q_w")[r], log.Column("q_x")[r], log.Column("q_y")[r], log.Column("q_z")[r]);
    const Eigen::Vector3d B_B(log.Column("mag_x_uT")[r], log.Column("mag_y_uT")[r], log.Column("mag_z_uT")[r]);
    const Eigen::Vector3d B_N = q * B_B;
    dec.push_back(std::atan2(B_N.y(), B_N.x()) * kRadToDeg);
    inc.push_back(std::atan2(B_N.z(), B_N.head<2>().norm()) * kRadToDeg);
  }
  EXPECT_NEAR(Quantile(dec, 0.5), 12.0, 8.0);
  EXPECT_NEAR(Quantile(inc, 0.5), -66.0, 6.0);
  EXPECT_EQ(log.meta["external_compass"], "mag");
}

TEST(DataFlashImport, GivenTheThreeCompasses_WhenMagnitudesAreTaken_ThenMagAndMag2AreEarthLikeAndMag3IsFarOff) {
  const FlightLog& log = RealImport().log;
  // |B| does not change with attitude; a calibrated compass reads a near-constant Earth field.
  for (const char* p : {"mag", "mag2"}) {
    const auto f = FieldMagnitudes(log, p);
    const double in_range = static_cast<double>(std::count_if(f.begin(), f.end(), [](double v) {
                              return v >= 25.0 && v <= 65.0;
                            })) / static_cast<double>(f.size());
    EXPECT_GT(in_range, 0.9) << p;
    EXPECT_GT(Quantile(f, 0.5), 45.0) << p;  // Canberra: about 57 µT
    EXPECT_LT(Quantile(f, 0.5), 65.0) << p;
    EXPECT_LT(Quantile(f, 0.95) - Quantile(f, 0.05), 15.0) << p;
  }
  // MAG3 is not calibrated (offsets 0, COMPASS_USE3 0): its magnitude swings with attitude.
  const auto f3 = FieldMagnitudes(log, "mag3");
  const double in_range3 =
      static_cast<double>(std::count_if(f3.begin(), f3.end(), [](double v) { return v >= 25.0 && v <= 65.0; })) /
      static_cast<double>(f3.size());
  EXPECT_LT(in_range3, 0.5);
  EXPECT_GT(Quantile(f3, 0.95) - Quantile(f3, 0.05), 30.0);
  const auto& compasses = log.meta["compasses"];
  ASSERT_EQ(compasses.size(), 3u);
  EXPECT_EQ(compasses[2]["column"], "mag3");
  EXPECT_EQ(compasses[2]["offsets_set"], false);
  EXPECT_EQ(compasses[2]["use"], false);
  EXPECT_EQ(compasses[0]["external"], true);
  EXPECT_EQ(compasses[1]["external"], false);
  EXPECT_NEAR(compasses[0]["offsets_mG"][0].get<double>(), -97.79, 0.01);  // COMPASS_OFS_X
}

TEST(DataFlashImport, GivenTheBatteryAndThrottle_WhenImported_ThenUnitsAreAmpsVoltsAndControlAmount) {
  const FlightLog& log = RealImport().log;
  const auto &i = log.Column("current_A"), &v = log.Column("voltage_V"), &u = log.Column("control_u");
  double i_min = 1e9, i_max = -1e9, v_min = 1e9, v_max = -1e9, u_max = 0;
  double su = 0, si = 0, suu = 0, sii = 0, sui = 0;
  size_t n = 0;
  for (size_t r = 0; r < log.rows(); ++r) {
    i_min = std::min(i_min, i[r]);
    i_max = std::max(i_max, i[r]);
    v_min = std::min(v_min, v[r]);
    v_max = std::max(v_max, v[r]);
    u_max = std::max(u_max, u[r]);
    su += u[r]; si += i[r]; suu += u[r] * u[r]; sii += i[r] * i[r]; sui += u[r] * i[r]; ++n;
  }
  // CURR Curr/Volt in hundredths: 0.52 .. 27.44 A, a 4S LiPo (4 x 3.7..4.2 V).
  EXPECT_NEAR(i_min, 0.52, 0.005);
  EXPECT_NEAR(i_max, 27.44, 0.005);
  EXPECT_GT(v_min, 4 * 3.5);
  EXPECT_LT(v_max, 4 * 4.25);
  EXPECT_LE(u_max, 1000.0);
  EXPECT_GT(u_max, 300.0);
  // Current follows throttle.
  const double dn = static_cast<double>(n);
  const double corr = (sui / dn - su / dn * si / dn) /
                      std::sqrt((suu / dn - su * su / dn / dn) * (sii / dn - si * si / dn / dn));
  EXPECT_GT(corr, 0.8);
  for (int m = 1; m <= 4; ++m) {
    for (double x : log.Column("motor_" + std::to_string(m) + "_u")) {
      if (std::isfinite(x)) {
        ASSERT_TRUE(x >= 0.0 && x <= 1.0);
      }
    }
  }
  EXPECT_EQ(log.meta["motor_pwm_range_us"]["source"], "RC3_MIN/MAX");
}

TEST(DataFlashImport, GivenGpsAndEkf_WhenImported_ThenTheyAgreeAndHeldSamplesAreNeverFromTheFuture) {
  const FlightLog& log = RealImport().log;
  const auto& t = log.Column("t_s");
  size_t n = 0, empty_before_fix = 0;
  double max_err = 0;
  for (size_t r = 0; r < log.rows(); ++r) {
    for (const char* tc : {"mag_t_s", "gps_t_s", "baro_t_s", "imu_t_s", "batt_t_s", "rcou_t_s"}) {
      const double ts = log.Column(tc)[r];
      if (std::isfinite(ts)) {
        ASSERT_LE(ts, t[r]) << tc;
      }
    }
    const double gn = log.Column("gps_N_m")[r];
    if (!std::isfinite(gn)) {
      ++empty_before_fix;
      EXPECT_LT(t[r], 46.0);  // first 3-D fix at 45.1 s
      continue;
    }
    // EKF origin and first fix are both near the take-off point; GPS ~1-2 m noise.
    max_err = std::max(max_err, std::hypot(gn - log.Column("pos_N_m")[r],
                                           log.Column("gps_E_m")[r] - log.Column("pos_E_m")[r]));
    ++n;
  }
  EXPECT_GT(empty_before_fix, 0u);
  EXPECT_GT(n, 2000u);
  EXPECT_LT(max_err, 8.0);
  EXPECT_NEAR(log.meta["location"]["lat_deg"].get<double>(), -35.3624, 0.001);  // CMAC, Canberra
  EXPECT_NEAR(log.meta["location"]["lon_deg"].get<double>(), 149.1659, 0.001);
  // GPS week 1871, late on Saturday 21 November 2015: 2015 + 324.99/365.
  EXPECT_NEAR(log.meta["date_decimal_year"].get<double>(), 2015.890, 0.001);
  EXPECT_EQ(log.meta["date_utc"].get<std::string>().substr(0, 10), "2015-11-21");
}

TEST(DataFlashImport, GivenModesInTheLog_WhenImported_ThenModeIsHeldFromEachModeMessage) {
  const FlightLog& log = RealImport().log;
  // MODE: Loiter (5) at 11.459 s and 74.618 s, Acro (1) at 217.209 s.
  for (size_t r = 0; r < log.rows(); ++r) {
    const double t = log.Column("t_s")[r];
    EXPECT_EQ(log.Column("mode")[r], t < 217.209 ? 5.0 : 1.0) << t;
  }
}

TEST(DataFlashImport, GivenTheArmEvent_WhenImported_ThenArmedIsZeroBeforeItAndOneFromIt) {
  const FlightLog& log = RealImport().log;
  ASSERT_TRUE(log.Has("armed"));
  // EV ARMED (id 10) at 74.688 s (3.3's EV carries no time: the latest timed message's); no disarm
  // before the log ends inverted.
  for (size_t r = 0; r < log.rows(); ++r) {
    const double t = log.Column("t_s")[r];
    EXPECT_EQ(log.Column("armed")[r], t < 74.688 ? 0.0 : 1.0) << t;
  }
}

TEST(DataFlashImport, GivenAnImport_WhenWrittenAndReadBack_ThenTheFlightLogReaderAcceptsItWithItsMeta) {
  // Per process: several checkouts may run this test at once.
  const std::string dir = ::testing::TempDir() + "/hexsim_import_test_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/log.csv";
  ASSERT_TRUE(WriteImport(RealImport(), path).ok());
  auto back = ReadFlightLog(path);
  ASSERT_TRUE(back.ok()) << back.status().message();
  EXPECT_EQ(back->rows(), RealImport().log.rows());
  EXPECT_EQ(back->columns(), RealImport().log.columns());
  EXPECT_EQ(back->meta["firmware"], "APM:Copter V3.3-dev (ae3192b8)");
  EXPECT_TRUE(std::isnan(back->Column("gps_N_m")[0]));  // empty cells stay empty
  EXPECT_EQ(back->Column("mag_x_uT")[100], RealImport().log.Column("mag_x_uT")[100]);
  std::filesystem::remove_all(dir);
}

TEST(DataFlashImport, GivenTheRealLog_WhenInfoIsAsked_ThenItListsTypesRatesAndCompassParameters) {
  const std::string info = DataFlashInfo(RealLogBytes(), "log171.bin");
  EXPECT_NE(info.find("ATT"), std::string::npos);
  EXPECT_NE(info.find("COMPASS_OFS_X"), std::string::npos);
  EXPECT_NE(info.find("APM:Copter V3.3"), std::string::npos);
  const auto j = DataFlashInfoJson(RealLogBytes(), "log171.bin");
  for (const auto& t : j["types"]) {
    if (t["name"] == "IMU") {
      EXPECT_NEAR(t["rate_hz"].get<double>(), 50.0, 1.5);  // 3.3 logs IMU at 50 Hz
    }
    if (t["name"] == "MAG") {
      EXPECT_EQ(t["count"], 2384);
    }
  }
  EXPECT_FALSE(IsParameterOfInterest("EKF_MAG_NOISE"));
  EXPECT_TRUE(IsParameterOfInterest("COMPASS_MOT2_X"));
}

// A public ArduCopter 3.3 log of a board without a working compass wrote MAG as (0, 0, 0) throughout:
// imported as a field, gap diagnosed it ("unexplained ... 13 isolated spikes"). A compass that never
// measured a field writes no columns; the meta and the warnings say why, and so does calibrate's input.
TEST(DataFlashImport, GivenACompassLoggingOneVectorThroughout_WhenImported_ThenItWritesNoColumnsAndSaysWhy) {
  testing::DataFlashWriter w;
  w.Fmt(130, "ATT", "QccccCCCC", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw");
  w.Fmt(131, "MAG", "Qhhhhhhhhh", "TimeUS,MagX,MagY,MagZ,OfsX,OfsY,OfsZ,MOfsX,MOfsY,MOfsZ");
  w.Fmt(132, "MAG2", "Qhhhhhhhhh", "TimeUS,MagX,MagY,MagZ,OfsX,OfsY,OfsZ,MOfsX,MOfsY,MOfsZ");
  for (int i = 0; i < 100; ++i) {
    const double t_us = 1e6 + 1e5 * i, yaw = 0.06 * i;  // the vehicle turns: a real compass follows
    w.Msg(130, "QccccCCCC", {t_us, 0, 0, 0, 0, 0, std::fmod(yaw * 5729.58, 36000.0), 0, 0});
    w.Msg(131, "Qhhhhhhhhh", {t_us, 0, 0, 0, 0, 0, 0, 0, 0, 0});
    w.Msg(132, "Qhhhhhhhhh", {t_us, std::round(250 * std::cos(yaw)), std::round(-250 * std::sin(yaw)), 400, 0, 0, 0, 0, 0, 0});
  }
  auto r = ImportDataFlash(w.bytes(), "no_compass.bin");
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_FALSE(r->log.Has("mag_x_uT"));
  EXPECT_TRUE(r->log.Has("mag2_x_uT"));
  ASSERT_EQ(r->log.meta["compasses_absent"].size(), 1U);
  EXPECT_EQ(r->log.meta["compasses_absent"][0]["column"], "mag");
  ASSERT_EQ(r->warnings.size(), 1U);
  EXPECT_NE(r->warnings[0].find("mag: every one of its 100 samples is (0, 0, 0)"), std::string::npos) << r->warnings[0];
  for (const auto& c : r->log.meta["compasses"]) EXPECT_NE(c["column"], "mag");
  auto in = ParseMagInput(w.bytes(), "no_compass.bin", "mag", nullptr);
  ASSERT_FALSE(in.ok());
  EXPECT_NE(in.status().message().find("no_compass.bin: mag: every one of its 100 samples"), std::string::npos)
      << in.status().message();
  EXPECT_TRUE(ParseMagInput(w.bytes(), "no_compass.bin", "mag2", nullptr).ok());
}

TEST(DataFlashImport, GivenGpsWeekAndTime_WhenConverted_ThenDecimalYearIsUtc) {
  // GPS week 1871 starts Sunday 2015-11-15 00:00:17 UTC - 17 leap s; day 318 of 365 (0-based).
  EXPECT_NEAR(DecimalYearFromGps(1871, 17.0), 2015.0 + 318.0 / 365.0, 1e-6);
  // 2020-01-01 00:00:00 UTC = GPS week 2086, 3 days + 18 s.
  EXPECT_NEAR(DecimalYearFromGps(2086, 3 * 86400.0 + 18.0), 2020.0, 1e-8);
}

}  // namespace
}  // namespace hexsim::logs
