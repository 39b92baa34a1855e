#include "hexsim/realdata/windows.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <gtest/gtest.h>

namespace hexsim::realdata {
namespace {

// A synthetic flight at 10 Hz: 10 s disarmed, 5 s armed at idle, 60 s flying (height 5 m with a
// vertical speed that flickers around zero near the ground at take-off), then a flip to 120 deg
// roll held for 5 s, then disarmed lying inverted.
logs::FlightLog SyntheticFlight(bool with_armed_column) {
  logs::FlightLog log;
  for (const char* c : {"t_s", "q_w", "q_x", "q_y", "q_z", "control_u", "pos_D_m", "vel_N_mps", "vel_E_mps", "vel_D_mps"}) {
    log.AddColumn(c);
  }
  if (with_armed_column) log.AddColumn("armed");
  for (int i = 0; i < 850; ++i) {
    const double t = 0.1 * i;
    log.AppendRow();
    const bool armed = t >= 10 && t < 80;
    const bool flying = t >= 15 && t < 75;
    const double roll = t >= 75 ? 2.1 : 0.0;  // rad: inverted after the flip
    log.Set("t_s", t);
    log.Set("q_w", std::cos(roll / 2));
    log.Set("q_x", std::sin(roll / 2));
    log.Set("q_y", 0.0);
    log.Set("q_z", 0.0);
    log.Set("control_u", flying ? 450.0 : (armed ? 80.0 : 0.0));
    const double h = flying ? std::min(5.0, 0.5 * (t - 15)) : 0.0;
    log.Set("pos_D_m", -h);
    log.Set("vel_N_mps", 0.0);
    log.Set("vel_E_mps", 0.0);
    log.Set("vel_D_mps", flying && h < 5 ? -0.5 : 0.05 * std::sin(7.0 * t));
    if (with_armed_column) log.Set("armed", armed ? 1.0 : 0.0);
  }
  return log;
}

TEST(FlightWindows, GivenAFlightEndingInAFlip_WhenWindowed_ThenFlightIsArmedAboveIdleAndTheFlipAndAfterAreExcluded) {
  const logs::FlightLog log = SyntheticFlight(true);
  const FlightWindows fw = FindFlightWindows(log);
  ASSERT_EQ(fw.windows.size(), 3u);
  EXPECT_EQ(fw.windows[0].kind, "ground");
  EXPECT_EQ(fw.windows[1].kind, "flight");
  EXPECT_EQ(fw.windows[2].kind, "excluded");
  EXPECT_NEAR(fw.windows[1].start_s, 15.0, 0.15);
  EXPECT_LT(fw.windows[1].end_s, 75.0);
  EXPECT_NEAR(fw.cut_at_s, 74.5, 0.15);  // where the tilt was last sane, lead_s earlier
  EXPECT_NEAR(fw.idle_throttle, 0.08, 1e-9);
  EXPECT_NE(fw.armed_source.find("armed column"), std::string::npos);
}

// The same motors at flight output, but tied down (or props off): the height stays within a few
// centimetres. The window is a flight window for the compasses (the current's field is the same on the
// ground) and not airborne for the inertial and dynamics replays.
TEST(FlightWindows, GivenMotorsAtFlightOutputWithoutAClimb_WhenWindowed_ThenTheWindowIsOnTheGroundAndNotAirborne) {
  logs::FlightLog log = SyntheticFlight(true);
  const size_t d = log.AddColumn("pos_D_m");
  auto& pos = log.MutableColumn(d);
  for (size_t i = 0; i < pos.size(); ++i) pos[i] = 0.03 * std::sin(0.9 * static_cast<double>(i));
  const FlightWindows fw = FindFlightWindows(log);
  ASSERT_EQ(fw.windows.size(), 3u);
  EXPECT_EQ(fw.windows[1].kind, "flight");
  EXPECT_TRUE(fw.windows[1].on_ground) << fw.windows[1].why;
  EXPECT_NE(fw.windows[1].why.find("run on the"), std::string::npos);
  const std::vector<RowKind> air = AirborneRowKind(log, fw);
  EXPECT_GT(fw.Count(RowKind::kFlight), 550u);
  EXPECT_EQ(std::count(air.begin(), air.end(), RowKind::kFlight), 0);
  // The flight that climbs 5 m is airborne.
  const FlightWindows flown = FindFlightWindows(SyntheticFlight(true));
  EXPECT_FALSE(flown.windows[1].on_ground);
  const std::vector<RowKind> flown_air = AirborneRowKind(SyntheticFlight(true), flown);
  EXPECT_EQ(static_cast<size_t>(std::count(flown_air.begin(), flown_air.end(), RowKind::kFlight)),
            flown.Count(RowKind::kFlight));
}

TEST(FlightWindows, GivenNoArmedColumn_WhenWindowed_ThenThrottleStandsInAndTheSourceSaysSo) {
  const FlightWindows fw = FindFlightWindows(SyntheticFlight(false));
  EXPECT_NE(fw.armed_source.find("no armed state"), std::string::npos);
  EXPECT_GT(fw.Count(RowKind::kFlight), 550u);
  EXPECT_GT(fw.Count(RowKind::kExcluded), 100u);
}

TEST(FlightWindows, GivenFlickeringVerticalSpeedOnTheGround_WhenPhasesAreLabelled_ThenGroundIsNeverLanding) {
  const logs::FlightLog log = SyntheticFlight(true);
  const auto ph = PhaseLabels(log, FindFlightWindows(log));
  const auto& t = log.Column("t_s");
  for (size_t i = 0; i < ph.size(); ++i) {
    if (t[i] < 15) {
      EXPECT_EQ(ph[i], "ground") << t[i];
    }
    if (t[i] >= 75) {
      EXPECT_EQ(ph[i], "excluded") << t[i];
    }
    EXPECT_NE(ph[i], "landing") << t[i];
  }
  // Every segment lasts at least 2 s (hysteresis), except at the ends of the log.
  for (size_t i = 1; i < ph.size();) {
    size_t j = i;
    while (j < ph.size() && ph[j] == ph[i]) ++j;
    if (j < ph.size()) {
      EXPECT_GE(t[j] - t[i], 2.0 - 1e-9) << ph[i] << " at " << t[i];
    }
    i = j;
  }
}

TEST(FlightWindows, GivenFromAndTo_WhenOverridden_ThenOnlyThatRangeIsFlight) {
  const FlightWindows fw = WindowsFromRange(SyntheticFlight(true), 19.95, 30.05);
  EXPECT_TRUE(fw.overridden);
  EXPECT_EQ(fw.Count(RowKind::kFlight), 101u);
}

TEST(MergeShortSegments, GivenAOneSampleBlip_WhenMerged_ThenItJoinsItsLongerNeighbourButFixedLabelsStay) {
  std::vector<double> t(100);
  for (int i = 0; i < 100; ++i) t[static_cast<size_t>(i)] = 0.1 * i;
  std::vector<std::string> l(100, "hover");
  l[40] = "landing";
  for (int i = 90; i < 100; ++i) l[i] = "excluded";
  l[89] = "climb";
  const auto m = MergeShortSegments(t, l, 2.0, {"excluded"});
  EXPECT_EQ(m[40], "hover");
  EXPECT_EQ(m[89], "hover");
  EXPECT_EQ(m[95], "excluded");
}

TEST(FlightWindows, GivenAnImpactSpikeTheVehicleFliesOnThrough_WhenWindowed_ThenNothingIsCut) {
  // Given: the synthetic flight with a single 8 g specific-force sample at 30 s, then flying on,
  // and the same spike at 74 s followed by the flip (a crash: the flight ends)
  logs::FlightLog log = SyntheticFlight(true);
  for (const char* c : {"accel_x_mps2", "accel_y_mps2", "accel_z_mps2"}) {
    auto& a = log.MutableColumn(log.AddColumn(c));
    for (size_t r = 0; r < log.rows(); ++r) a[r] = c[6] == 'z' ? -9.81 : 0.0;
  }
  auto& az = log.MutableColumn(log.AddColumn("accel_z_mps2"));
  az[300] = -80.0;
  // When
  const FlightWindows bump = FindFlightWindows(log);
  az[745] = -80.0;
  const FlightWindows crash = FindFlightWindows(log);
  // Then: the bump cuts nothing (the flip still does, at 74.5 s); the impact before the flip cuts there
  EXPECT_NEAR(bump.cut_at_s, 74.5, 0.15);
  EXPECT_EQ(bump.cut_why.find("impact"), std::string::npos) << bump.cut_why;
  EXPECT_NEAR(crash.cut_at_s, 74.0, 0.15);
  EXPECT_NE(crash.cut_why.find("impact"), std::string::npos) << crash.cut_why;
}

}  // namespace
}  // namespace hexsim::realdata
