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

// Appends a row at t with attitude q, compass reading m stamped mag_t, and the current I.
void AppendRow(logs::FlightLog* log, double t, const Eigen::Quaterniond& q, const Vector3d& m, double mag_t, double I) {
  log->AppendRow();
  log->Set("t_s", t);
  log->Set("q_w", q.w());
  log->Set("q_x", q.x());
  log->Set("q_y", q.y());
  log->Set("q_z", q.z());
  log->Set("mag_x_uT", m(0));
  log->Set("mag_y_uT", m(1));
  log->Set("mag_z_uT", m(2));
  log->Set("mag_t_s", mag_t);
  log->Set("current_A", I);
}

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
    AppendRow(&log, t, q, m, t, I);
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

// A public ArduCopter 4.6 log with one 4-s hop at 11 A (no flight window): calibrate said "current not
// used: no current logged in flight" beside an import that had just found the current usable.
TEST(CompassFlight, GivenNoFlightWindow_WhenFitted_ThenTheCurrentNoteSaysThereIsNoFlightNotNoCurrent) {
  const logs::FlightLog log = Flight(0.0, Vector3d::Zero());
  auto in = logs::MagInputFromFlightLog(log, "synthetic", "mag");
  ASSERT_TRUE(in.ok()) << in.status().message();
  FlightWindows w = WindowsFromRange(log, 0.0, 200.0);
  std::fill(w.row_kind.begin(), w.row_kind.end(), RowKind::kGround);
  w.windows.clear();
  CompassFlightOptions o;
  o.scan_latency = false;
  auto f = FitCompassInFlight(log, *in, w, o);
  ASSERT_TRUE(f.ok()) << f.status().message();
  EXPECT_FALSE(f->current_usable);
  EXPECT_NE(f->current_note.find("no flight window"), std::string::npos) << f->current_note;
  EXPECT_EQ(f->current_note.find("no current logged"), std::string::npos) << f->current_note;
}

// A public ArduCopter 4.7.0-dev log (quiver pt2_00000002) ran its motors at output 0.4-0.9 on the
// ground, props off (0.66 A per motor on 12S, the barometer within 0.2 m); calibrate wrote a throttle
// compensation from it in place of the log's current compensation. A fit that saw no flight says so.
TEST(CompassFlight, GivenOnlyARunOnTheGround_WhenFitted_ThenItsTermIsMarkedAsNoFlightsAndAFlightsIsNot) {
  const logs::FlightLog log = Flight(0.0, Vector3d::Zero());
  auto in = logs::MagInputFromFlightLog(log, "synthetic", "mag");
  ASSERT_TRUE(in.ok()) << in.status().message();
  CompassFlightOptions o;
  o.scan_latency = false;
  FlightWindows ground = WindowsFromRange(log, 0.0, 200.0);
  for (Window& w : ground.windows) w.on_ground = w.kind == "flight";
  auto on_ground = FitCompassInFlight(log, *in, ground, o);
  auto flown = FitCompassInFlight(log, *in, WindowsFromRange(log, 0.0, 200.0), o);
  ASSERT_TRUE(on_ground.ok()) << on_ground.status().message();
  ASSERT_TRUE(flown.ok()) << flown.status().message();
  EXPECT_NE(on_ground->ground_run_note.find("runs on the ground only"), std::string::npos) << on_ground->ground_run_note;
  EXPECT_TRUE(flown->ground_run_note.empty()) << flown->ground_run_note;
  // ground samples used for want of flight ones: no flight either
  FlightWindows none = WindowsFromRange(log, 0.0, 200.0);
  std::fill(none.row_kind.begin(), none.row_kind.end(), RowKind::kGround);
  none.windows.clear();
  auto grounded = FitCompassInFlight(log, *in, none, o);
  ASSERT_TRUE(grounded.ok()) << grounded.status().message();
  EXPECT_NE(grounded->ground_run_note.find("ground samples"), std::string::npos) << grounded->ground_run_note;
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

// The trial shifts of the logged current (CurrentShiftGrid): from 0 to the throttle scan's upper
// bound plus one update period, in quarter periods within [10, 50] ms, never past the staleness's
// physical range (plausibility row current_staleness, 0..1 s); the whole range without a scan.
TEST(CompassFlight, GivenAThrottleScan_WhenTheCurrentsShiftsAreMade_ThenTheyRunFromZeroToItsUpperBoundPlusAPeriod) {
  LagEstimate scan;
  scan.value_s = 0.38;
  scan.ci95_s[0] = 0.34;
  scan.ci95_s[1] = 0.42;
  const std::vector<double> g = CurrentShiftGrid(scan, 0.2);  // a 5 Hz current
  ASSERT_GE(g.size(), 2u);
  EXPECT_DOUBLE_EQ(g.front(), 0.0);  // below the scan's own interval: the motors' response is in it
  EXPECT_NEAR(g.back(), 0.6, 1e-9);
  for (size_t k = 1; k < g.size(); ++k) EXPECT_NEAR(g[k] - g[k - 1], 0.05, 1e-9);
  EXPECT_NEAR(CurrentShiftGrid(scan, 0.02)[1], kMinShiftStep_s, 1e-12);  // a 50 Hz current
  scan.value_s = 0.95;
  scan.ci95_s[0] = 0.9;
  scan.ci95_s[1] = 0.99;
  EXPECT_LE(CurrentShiftGrid(scan, 0.2).back(), 1.0 + 1e-9);
  const std::vector<double> none = CurrentShiftGrid(LagEstimate(), 0.1);
  EXPECT_DOUBLE_EQ(none.front(), 0.0);
  EXPECT_NEAR(none.back(), 1.0, 1e-9);
  EXPECT_NEAR(UpdatePeriod_s({0.0, 0.2, 0.4, 0.6, 0.9}), 0.2, 1e-12);
}

// 50 Hz rows over 150 s of a yawing quad whose battery current swings at 0.27-0.7 Hz (throttle
// bursts); the current follows the throttle through the motors' response (0.2 s) and is logged at
// 10 Hz, each sample 0.1 s old. The scan against the throttle reads the two together (~0.3 s).
logs::FlightLog StaleCurrentFlight() {
  const double lat = 48.1, lon = 11.6, alt = 500.0, year = 2023.5;
  const Vector3d B_N = magnetics::EvaluateWmm({lat, lon, alt}, year, true)->B_N_uT;
  constexpr double kMotorResponse_s = 0.2, kStale_s = 0.1, kPeriod_s = 0.1;
  auto current = [](double t) {
    return 15.0 + 5.0 * std::sin(2 * M_PI * 0.45 * t) + 3.0 * std::sin(2 * M_PI * 0.27 * t + 1.0) +
           2.0 * std::sin(2 * M_PI * 0.7 * t + 2.0);
  };
  logs::FlightLog log;
  for (const char* c : {"t_s", "q_w", "q_x", "q_y", "q_z", "mag_x_uT", "mag_y_uT", "mag_z_uT", "mag_t_s", "current_A",
                        "batt_t_s", "control_u"}) {
    log.AddColumn(c);
  }
  unsigned noise = 777;
  auto uniform = [&noise] {
    noise = noise * 1103515245u + 12345u;
    return static_cast<double>((noise >> 8) & 0xFFFF) / 65535.0 - 0.5;
  };
  Vector3d m = Vector3d::Zero();
  double mag_t = 0.0;
  for (int i = 0; i < 7500; ++i) {
    const double t = 0.02 * i;
    const Eigen::Quaterniond q = Eigen::AngleAxisd(2 * M_PI * t / 25.0, Vector3d::UnitZ()) *
                                 Eigen::AngleAxisd(0.26 * std::cos(t / 5.0), Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(0.26 * std::sin(t / 3.0), Vector3d::UnitX());
    if (i % 5 == 0) {  // a 10 Hz compass
      m = q.toRotationMatrix().transpose() * B_N + kOffset_uT + kCurrentField_uT_per_A * current(t) +
          2.0 * Vector3d(uniform(), uniform(), uniform());
      mag_t = t;
    }
    const double update = kPeriod_s * std::floor(t / kPeriod_s + 1e-9);
    AppendRow(&log, t, q, m, mag_t, current(update - kStale_s));
    log.Set("batt_t_s", update);
    log.Set("control_u", 300.0 + 20.0 * current(t + kMotorResponse_s));  // the current follows it 0.2 s later
  }
  log.meta = {{"location", {{"lat_deg", lat}, {"lon_deg", lon}, {"alt_m", alt}}},
              {"date_decimal_year", year},
              {"motor_count", 4},
              {"current_usable", true}};
  return log;
}

// The scan against the throttle holds the motors' response: the current shifted by it (0.3 s where
// the field sees it 0.1 s late) read k a sixth low, its interval short of the truth. The shift profiled by the compass fit lands
// on the staleness, and k's interval covers the truth.
TEST(CompassFlight, GivenACurrentStalerAgainstTheThrottleThanAgainstTheField_WhenFitted_ThenTheCompassChoosesItsShift) {
  const logs::FlightLog log = StaleCurrentFlight();
  auto in = logs::MagInputFromFlightLog(log, "synthetic", "mag");
  ASSERT_TRUE(in.ok()) << in.status().message();
  CompassFlightOptions o;
  o.scan_latency = false;
  auto f = FitCompassInFlight(log, *in, WindowsFromRange(log, 0.0, 200.0), o);
  ASSERT_TRUE(f.ok()) << f.status().message();
  ASSERT_TRUE(f->staleness.ok());
  EXPECT_GT(f->staleness.value_s, 0.2) << TimingNote(*f);  // the case: the scan reads the motors' response too
  ASSERT_TRUE(f->fit.term_fitted) << f->fit.term_note;
  EXPECT_NEAR(f->current_shift_s, 0.1, 0.025 + 1e-9) << TimingNote(*f);
  EXPECT_LE(f->current_shift_range_s[0], f->current_shift_s);
  EXPECT_GE(f->current_shift_range_s[1], f->current_shift_s);
  const double truth = kCurrentField_uT_per_A.norm();
  EXPECT_LE(f->fit.term_norm_ci95[0], truth) << TimingNote(*f);
  EXPECT_GE(f->fit.term_norm_ci95[1], truth) << TimingNote(*f);
  EXPECT_NE(TimingNote(*f).find("chosen by the compass fit"), std::string::npos) << TimingNote(*f);
}


// A caller that fits several compasses of one log scans the current's staleness once and hands it
// over: the fit takes it as its own (the same scan, not repeated) and bounds its shift grid by it.
TEST(CompassFlight, GivenTheStalenessScannedByTheCaller_WhenFitted_ThenTheFitTakesItAndBoundsItsShiftsByIt) {
  const logs::FlightLog log = StaleCurrentFlight();
  auto in = logs::MagInputFromFlightLog(log, "synthetic", "mag");
  ASSERT_TRUE(in.ok()) << in.status().message();
  CompassFlightOptions o;
  o.scan_latency = false;
  const FlightWindows w = WindowsFromRange(log, 0.0, 200.0);
  auto own = FitCompassInFlight(log, *in, w, o);
  ASSERT_TRUE(own.ok()) << own.status().message();
  ASSERT_TRUE(own->staleness.ok());
  StalenessOptions so;
  so.seed = o.seed;
  so.resamples = o.resamples;
  const LagEstimate scanned = CurrentStaleness(log, w.row_kind, so);
  EXPECT_EQ(scanned.value_s, own->staleness.value_s);  // the caller's scan is the fit's own
  LagEstimate given = scanned;  // a different scan result, to see that it is the one used
  given.value_s = 0.05;
  given.ci95_s[0] = 0.0;
  given.ci95_s[1] = 0.1;
  o.staleness = &given;
  auto f = FitCompassInFlight(log, *in, w, o);
  ASSERT_TRUE(f.ok()) << f.status().message();
  EXPECT_EQ(f->staleness.value_s, 0.05);
  EXPECT_NE(f->current_shift_grid_s, own->current_shift_grid_s);  // bounded by the given scan
}

}  // namespace
}  // namespace hexsim::realdata
