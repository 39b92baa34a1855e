// The in-flight compass model's input side (compass_flight.h) on synthetic FlightLogs with a known
// current field.
#include "hexsim/realdata/compass_flight.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "hexsim/logs/mag_input.h"
#include "hexsim/magnetics/wmm.h"

namespace hexsim::realdata {
namespace {

using Eigen::Vector3d;

const Vector3d kCurrentField_uT_per_A(0.2, -0.3, 0.1);  // |d| = 3.7 mG/A
const Vector3d kOffset_uT(6.0, -4.0, 12.0);

// 10 Hz rows over 120 s of a quad (4 motors) yawing through full turns with ±15° roll/pitch. The
// first `ground_s` seconds hold the motors stopped (0 A) where the vehicle stands on the ground, whose
// local field differs from the airborne one by `ground_anomaly_uT`; the rest fly at 8-20 A.
logs::FlightLog Flight(double ground_s, const Vector3d& ground_anomaly_uT) {
  const double lat = 48.1, lon = 11.6, alt = 500.0, year = 2023.5;
  const Vector3d B_N = magnetics::EvaluateWmm({lat, lon, alt}, year, true)->B_N_uT;
  logs::FlightLog log;
  for (const char* c : {"t_s", "q_w", "q_x", "q_y", "q_z", "mag_x_uT", "mag_y_uT", "mag_z_uT", "mag_t_s", "current_A"}) {
    log.AddColumn(c);
  }
  unsigned noise = 12345;
  auto uniform = [&noise] {
    noise = noise * 1103515245u + 12345u;
    return static_cast<double>((noise >> 8) & 0xFFFF) / 65535.0 - 0.5;
  };
  for (int i = 0; i < 1200; ++i) {
    const double t = 0.1 * i;
    const bool ground = t < ground_s;
    const double yaw = 2 * M_PI * t / 30.0, roll = ground ? 0.0 : 0.26 * std::sin(t / 3.0),
                 pitch = ground ? 0.0 : 0.26 * std::cos(t / 5.0);
    const Eigen::Quaterniond q = Eigen::AngleAxisd(yaw, Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(roll, Vector3d::UnitX());
    const double I = ground ? 0.0 : 14.0 + 6.0 * std::sin(t / 7.0) * std::cos(t / 2.3);
    Vector3d m = q.toRotationMatrix().transpose() * B_N + kOffset_uT + kCurrentField_uT_per_A * I;
    if (ground) m += ground_anomaly_uT;
    m += 0.6 * Vector3d(uniform(), uniform(), uniform());
    log.AppendRow();
    log.Set("t_s", t);
    log.Set("q_w", q.w());
    log.Set("q_x", q.x());
    log.Set("q_y", q.y());
    log.Set("q_z", q.z());
    log.Set("mag_x_uT", m(0));
    log.Set("mag_y_uT", m(1));
    log.Set("mag_z_uT", m(2));
    log.Set("mag_t_s", t);
    log.Set("current_A", I);
  }
  log.meta = {{"location", {{"lat_deg", lat}, {"lon_deg", lon}, {"alt_m", alt}}},
              {"date_decimal_year", year},
              {"motor_count", 4},
              {"current_usable", true}};
  return log;
}

Result<CompassFlight> Fit(const logs::FlightLog& log, double min_current_per_motor_A) {
  auto in = logs::MagInputFromFlightLog(log, "synthetic", "mag");
  if (!in.ok()) return in.status();
  CompassFlightOptions o;
  o.scan_latency = false;
  o.min_current_per_motor_A = min_current_per_motor_A;
  // Every row in the window, as a window's hysteresis can hold a log's first seconds on the ground.
  return FitCompassInFlight(log, *in, WindowsFromRange(log, 0.0, 200.0), o);
}

// ArduCopter log_0041 (public, ardupilot-discuss): its first flight window starts with 2.1 s of
// motors stopped at 0 A; those ground samples levered the current term from 4.0 to 5.6 mG/A.
TEST(CompassFlight, GivenAFlightWindowStartingWithTheMotorsStopped_WhenFitted_ThenThoseSamplesAreLeftOutAndTheTermHolds) {
  const logs::FlightLog log = Flight(5.0, Vector3d(0.0, 6.0, -12.0));  // a 13 uT anomaly on the pad (rebar)
  auto f = Fit(log, 0.5);
  ASSERT_TRUE(f.ok()) << f.status().message();
  EXPECT_EQ(f->not_airborne, 50);
  EXPECT_NE(f->windows_note.find("50 sample(s) under 2.0 A"), std::string::npos) << f->windows_note;
  ASSERT_TRUE(f->fit.term_fitted);
  const double truth = kCurrentField_uT_per_A.norm();
  EXPECT_LE(f->fit.term_norm_ci95[0], truth);
  EXPECT_GE(f->fit.term_norm_ci95[1], truth);
  // The same log with the bound off: the ground samples pull the term off the truth.
  auto off = Fit(log, 0.0);
  ASSERT_TRUE(off.ok()) << off.status().message();
  EXPECT_EQ(off->not_airborne, 0);
  EXPECT_GT(std::fabs(off->fit.term_norm_uT - truth), std::fabs(f->fit.term_norm_uT - truth));
  EXPECT_GT(std::fabs(off->fit.term_norm_uT - truth), 0.2 * truth) << off->fit.term_norm_uT << " truth " << truth;
}

// A short PX4 log (ZweiterFlugtag log_18, 1 Hz sensor_mag): its armed window held 35 compass samples,
// 6 of them before the motors carried the vehicle; the refusal said "29 samples with an attitude" as
// if the attitude lookup had lost samples. It names where the samples went.
TEST(CompassFlight, GivenTooFewAirborneSamples_WhenFitted_ThenTheRefusalSaysWhereTheSamplesWent) {
  const logs::FlightLog log = Flight(117.5, Vector3d::Zero());
  auto in = logs::MagInputFromFlightLog(log, "synthetic", "mag");
  ASSERT_TRUE(in.ok()) << in.status().message();
  CompassFlightOptions o;
  o.scan_latency = false;
  // A window of 45 samples, the first 20 on the ground: 25 airborne.
  auto f = FitCompassInFlight(log, *in, WindowsFromRange(log, 115.45, 200.0), o);
  ASSERT_FALSE(f.ok());
  const std::string& why = f.status().message();
  EXPECT_NE(why.find("flight fit: 25 samples, needs at least 30"), std::string::npos) << why;
  EXPECT_NE(why.find("1155 lie outside the flight windows, 0 tilted beyond 60 deg, 20 under 2.0 A"), std::string::npos) << why;
  EXPECT_EQ(why.find("attitude"), std::string::npos) << why;
}

// A log without a GPS fix (six Erle logs of the corpus) has no place and date for the WMM: the model's
// Earth-field terms are fitted freely, and the fit still finds the field, the offset and the current
// term (it was refused: "no place and date").
TEST(CompassFlight, GivenALogWithoutAPlace_WhenFitted_ThenTheEarthFieldIsFittedFreely) {
  logs::FlightLog log = Flight(0.0, Vector3d::Zero());
  const Vector3d B_N = magnetics::EvaluateWmm({48.1, 11.6, 500.0}, 2023.5, true)->B_N_uT;
  log.meta.erase("location");
  log.meta.erase("date_decimal_year");
  auto f = Fit(log, 0.5);
  ASSERT_TRUE(f.ok()) << f.status().message();
  EXPECT_TRUE(f->options.field_free);
  EXPECT_NE(TimingNote(*f).find("fitted freely"), std::string::npos) << TimingNote(*f);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(f->fit.field_N_uT(k), B_N(k), std::max(0.3, f->fit.field_ci_half_uT(k))) << k;
    EXPECT_NEAR(f->fit.offset_y_uT(k), kOffset_uT(k), std::max(0.3, f->fit.offset_ci_half_uT(k))) << k;
  }
  const double truth = kCurrentField_uT_per_A.norm();
  EXPECT_LE(f->fit.term_norm_ci95[0], truth);
  EXPECT_GE(f->fit.term_norm_ci95[1], truth);
}

}  // namespace
}  // namespace hexsim::realdata
