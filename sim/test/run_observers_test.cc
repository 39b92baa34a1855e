// The run's observers (LogRecorder, RunScorer) on hand-made step records: no ODE, no autopilot.
#include "hexsim/sim/step_record.h"

#include <cmath>

#include <gtest/gtest.h>

namespace hexsim::sim {
namespace {

// A record of a vehicle 3 m east of a north-going leg, yaw estimate 2° off, 6 motors at 0.4.
struct Fixture {
  BodyState truth;
  vehicle::SensorReadings readings;
  nav::NavEstimate estimate;
  std::vector<double> commands = std::vector<double>(6, 0.4);
  vehicle::PowertrainOutput pt;

  Fixture() {
    truth.p_N_m = Eigen::Vector3d(5.0, 3.0, -10.0);
    estimate.q_NB = Eigen::Quaterniond(Eigen::AngleAxisd(2.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()));
    pt.motors.resize(6);
    pt.bus_V = 24.0;
    pt.battery_A = 40.0;
    pt.power_in_W = 960.0;
  }
  StepRecord Record(int64_t step, control::FlightMode mode) const {
    StepRecord r;
    r.step = step;
    r.t_s = 0.001 * static_cast<double>(step);
    r.truth = &truth;
    r.readings = &readings;
    r.estimate = &estimate;
    r.estimated = true;
    r.commands = &commands;
    r.powertrain = &pt;
    r.mode = mode;
    r.active_leg = 0;
    r.landed = false;
    return r;
  }
};

TEST(RunScorer, GivenStepsOnALegAndOnTheGround_WhenScored_ThenOnlyTheLegCountsForCrossTrackAndYaw) {
  const Fixture f;
  RunScorer scorer({Eigen::Vector3d(0, 0, -10), Eigen::Vector3d(100, 0, -10)});
  for (int k = 0; k < 10; ++k) scorer.OnStep(f.Record(k, control::FlightMode::kWaypoint));
  scorer.OnStep(f.Record(10, control::FlightMode::kTakeoff));  // not on a leg: yaw_all only
  StepInterval iv;
  iv.dt_s = 0.5;
  iv.powertrain = &f.pt;
  iv.p_after_N_m = Eigen::Vector3d(3.0, 4.0, 0.0);
  scorer.OnInterval(iv);
  RunSummary sum;
  scorer.WriteSummary(&sum);
  EXPECT_NEAR(sum.cross_track_m.max, 3.0, 1e-12);
  EXPECT_NEAR(sum.cross_track_m.rms, 3.0, 1e-12);
  EXPECT_NEAR(sum.yaw_error_deg.max, 2.0, 1e-9);
  EXPECT_EQ(scorer.yaw_error_deg().n, 10);
  EXPECT_EQ(scorer.yaw_error_all_deg().n, 11);
  EXPECT_NEAR(sum.energy_Wh, 960.0 * 0.5 / 3600.0, 1e-12);
  EXPECT_NEAR(sum.distance_m, 5.0, 1e-12);
  EXPECT_EQ(sum.current_max_A, 40.0);
}

TEST(LogRecorder, GivenTenRecordsAndEveryFifthLogged_WhenRecorded_ThenTwoRowsCarryTheRecordsValues) {
  const Fixture f;
  logs::FlightLog log;
  LogRecorder recorder(&log, 6, 1, 5);
  for (int k = 0; k < 10; ++k) recorder.OnStep(f.Record(k, control::FlightMode::kWaypoint));
  ASSERT_EQ(log.rows(), 2u);
  EXPECT_EQ(log.Column(recorder.time_column())[1], 0.005);
  const auto col = [&](const std::string& name) { return log.Column(name); };
  EXPECT_EQ(col("pos_E_m")[0], 3.0);
  EXPECT_EQ(col("motor_6_u")[1], 0.4);
  EXPECT_EQ(col("voltage_V")[0], 24.0);
  EXPECT_NEAR(col("yaw_est_deg")[0], 2.0, 1e-9);
  EXPECT_TRUE(std::isnan(col("gps_N_m")[0]));  // no GPS sample yet
}


TEST(LogRecorder, GivenStreamsAt50Hz_WhenAFourHundredHertzImuIsRecorded_ThenEachStreamKeepsEveryEighthSampleWithItsOwnTime) {
  Fixture f;
  logs::FlightLog log;
  LogRecorder rec(&log, 6, 0, 100);  // table at 10 Hz of a 1 kHz loop
  rec.EnableStreams(50.0);
  for (int64_t k = 0; k <= 1000; ++k) {
    f.readings.gyro_radps.fresh = k % 5 == 2;  // 200 Hz IMU, sampled 2 ms into each period
    f.readings.gyro_radps.valid = k >= 2;
    if (f.readings.gyro_radps.fresh) f.readings.gyro_radps.t_s = 0.001 * static_cast<double>(k);
    f.readings.gyro_radps.value = Eigen::Vector3d(0.001 * static_cast<double>(k), 0, 0);
    f.commands[0] = 0.001 * static_cast<double>(k);
    rec.OnStep(f.Record(k, control::FlightMode::kWaypoint));
  }
  rec.AttachStreams();
  EXPECT_EQ(log.rows(), 11u);  // the table is untouched by the streams
  for (const char* name : {"imu", "rcou", "batt"}) {
    const logs::FlightLog* s = log.Stream(name);
    ASSERT_NE(s, nullptr) << name;
    const auto& t = s->Column("t_s");
    ASSERT_GE(t.size(), 50u) << name;
    EXPECT_LE(t.size(), 51u) << name;
    for (size_t i = 1; i < t.size(); ++i) EXPECT_NEAR(t[i] - t[i - 1], 0.02, 1e-9) << name << " sample " << i;
  }
  // Each sample carries its own time and the value of that instant, never a resampled one.
  const logs::FlightLog& imu = *log.Stream("imu");
  EXPECT_NEAR(imu.Column("t_s")[0], 0.002, 1e-12);
  for (size_t i = 0; i < imu.rows(); ++i) EXPECT_NEAR(imu.Column("gyro_x_radps")[i], imu.Column("t_s")[i], 1e-12);
  const logs::FlightLog& rcou = *log.Stream("rcou");
  for (size_t i = 0; i < rcou.rows(); ++i) EXPECT_NEAR(rcou.Column("motor_1_u")[i], rcou.Column("t_s")[i], 1e-12);
  EXPECT_NEAR(log.Stream("batt")->Column("voltage_V")[0], 24.0, 1e-12);
}

TEST(LogRecorder, GivenNoStreamsEnabled_WhenRecorded_ThenTheLogHasNoStreams) {
  const Fixture f;
  logs::FlightLog log;
  LogRecorder rec(&log, 6, 0, 1);
  for (int64_t k = 0; k < 10; ++k) rec.OnStep(f.Record(k, control::FlightMode::kWaypoint));
  rec.AttachStreams();
  EXPECT_TRUE(log.stream_names().empty());
  EXPECT_EQ(log.rows(), 10u);
}

}  // namespace
}  // namespace hexsim::sim
