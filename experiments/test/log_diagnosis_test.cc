#include "hexsim/experiments/log_diagnosis.h"

#include <string>

#include <gtest/gtest.h>

#include "hexsim/logs/dataflash_import.h"

namespace hexsim::experiments {
namespace {

// A log with a time column and nothing to tell its frame by (no parameters, no motor outputs).
logs::FlightLog FramelessLog() {
  logs::FlightLog log;
  for (int i = 0; i < 10; ++i) {
    log.AppendRow();
    log.Set("t_s", 0.1 * i);
  }
  return log;
}

// A quad's log (FRAME 1, four motors) with too little flight to identify the vehicle.
logs::FlightLog ShortQuadLog() {
  logs::FlightLog log = FramelessLog();
  log.meta["params"] = {{"FRAME", 1}};
  log.meta["motor_count"] = 4;
  return log;
}

TEST(DiagnoseLog, GivenAnEmptyLogThenItIsBadInputNamingTheLog) {
  LogDiagnosisOptions o;
  o.log_name = "flight.csv";
  o.vehicle = "paper_hex";
  auto d = DiagnoseLog(logs::FlightLog{}, o);
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.status().code(), StatusCode::kBadInput);
  EXPECT_EQ(d.status().message(), "flight.csv: no data rows");
}

TEST(DiagnoseLog, GivenNoVehicleAndNoWayToTellTheFrameThenItAsksForOne) {
  LogDiagnosisOptions o;
  o.log_name = "flight.csv";
  auto d = DiagnoseLog(FramelessLog(), o);
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.status().code(), StatusCode::kBadInput);
  EXPECT_EQ(d.status().message(),
            "flight.csv: frame: not determined (no frame parameters, and no motor count, 0 active motor outputs: not a "
            "quad, hex or octo); give --sim VEHICLE");
}

TEST(DiagnoseLog, GivenAVehicleAndAToBeforeTheFromThenItIsBadInput) {
  LogDiagnosisOptions o;
  o.log_name = "flight.csv";
  o.vehicle = "paper_hex";
  o.from_s = 5.0;
  o.to_s = 2.0;
  auto d = DiagnoseLog(FramelessLog(), o);
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.status().code(), StatusCode::kBadInput);
  EXPECT_EQ(d.status().message(), "--from/--to: --to must be after --from");
}

// `gap diagnose --sim paper_hex` on a public quad log (ArduCopter 3.4.6, four motors) ran against a
// six-rotor airframe without a word; identify refused the same pairing. Refused the same way here.
TEST(DiagnoseLog, GivenAVehicleWithAnotherRotorCountThenItIsBadInputNamingBothCounts) {
  LogDiagnosisOptions o;
  o.log_name = "flight.csv";
  o.vehicle = "paper_hex";
  auto d = DiagnoseLog(ShortQuadLog(), o);
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.status().code(), StatusCode::kBadInput);
  EXPECT_EQ(d.status().message(), "flight.csv: --sim: 'paper_hex' has 6 rotors, the log drives 4 motors (motor_count): "
                                  "give a vehicle with 4 rotors (e.g. quad_x)");
  o.vehicle = "quad_x";  // the same count: no such refusal
  auto q = DiagnoseLog(ShortQuadLog(), o);
  if (!q.ok()) {
    EXPECT_EQ(q.status().message().find("rotors"), std::string::npos) << q.status().message();
  }
}

// A quad's log with too little flight to identify the vehicle: not bad input (CONTRACTS: diagnose what
// can be diagnosed); the base vehicle of the frame class is used on the whole log, and the output says
// why.
TEST(DiagnoseLog, GivenNoVehicleAndALogTooShortToIdentifyThenTheBaseVehicleIsUsedAndSaidSo) {
  LogDiagnosisOptions o;
  o.log_name = "flight.csv";
  const logs::FlightLog log = ShortQuadLog();
  auto d = DiagnoseLog(log, o);
  ASSERT_TRUE(d.ok()) << d.status().message();
  EXPECT_FALSE(d->identified);
  EXPECT_EQ(d->stem, "quad_x");
  EXPECT_EQ(d->vehicle_source["mode"], "base (identification not possible)");
  EXPECT_NE(d->vehicle_source["why"].get<std::string>().find("identification needs"), std::string::npos)
      << d->vehicle_source.dump();
  ASSERT_FALSE(d->lines.empty());
  EXPECT_NE(d->lines.back().find("could not be identified"), std::string::npos);
}

// Without --sim the shipped base's wiring is hexsim's airframe's, not the log's: the compasses are
// compared with no modelled current field (so a compass's gap is its whole current field, the
// in-flight model's absolute term), the vehicle file written beside the diagnosis says so, and the
// output says so. With --sim the user's vehicle keeps its wiring.
TEST(DiagnoseLog, GivenNoVehicleThenTheBasesWiringIsNotModelledAndSaidSo) {
  LogDiagnosisOptions o;
  o.log_name = "flight.csv";
  const logs::FlightLog log = ShortQuadLog();
  auto d = DiagnoseLog(log, o);
  ASSERT_TRUE(d.ok()) << d.status().message();
  EXPECT_TRUE(d->vehicle.wiring.segments.empty());
  EXPECT_TRUE(d->vehicle.wiring.dipoles.empty());
  EXPECT_EQ(d->vehicle_yaml.find("\nwiring:"), std::string::npos) << d->vehicle_yaml.substr(0, 400);
  EXPECT_NE(d->vehicle_yaml.find("# wiring: removed"), std::string::npos);
  EXPECT_TRUE(d->vehicle_source.contains("wiring")) << d->vehicle_source.dump();
  bool said = false;
  for (const auto& l : d->lines) said = said || l.find("no modelled current field") != std::string::npos;
  EXPECT_TRUE(said);

  o.vehicle = "quad_x";
  auto given = DiagnoseLog(log, o);
  ASSERT_TRUE(given.ok()) << given.status().message();
  EXPECT_FALSE(given->vehicle.wiring.segments.empty());
}

const gap::ChannelResult* Channel(const gap::GapReport& r, const std::string& name) {
  for (const auto& c : r.channels) {
    if (c.channel == name) return &c;
  }
  return nullptr;
}

// Without --sim the vehicle is identified on the even blocks and what its fit could have absorbed
// (gyro, accel, dynamics) is diagnosed on the odd blocks only; a compass's replay uses nothing the
// identification fits (the log's attitude, current and outputs), so the compasses are diagnosed on
// every block, as the whole log is: twice the held-out half's samples, and said so.
TEST(DiagnoseLog, GivenNoVehicleThenTheCompassesUseEveryBlockAndTheInertialChannelsTheHeldOutOnes) {
  auto imp = logs::ImportDataFlashFile(std::string(HEXSIM_SOURCE_DIR) + "/data/real/ardupilot_copter_log171.bin");
  ASSERT_TRUE(imp.ok()) << imp.status().message();
  LogDiagnosisOptions o;
  o.log_name = "log171.bin";
  auto d = DiagnoseLog(imp->log, o);
  ASSERT_TRUE(d.ok()) << d.status().message();
  ASSERT_TRUE(d->identified) << d->vehicle_source.dump();
  gap::DiagnoseOptions whole;
  whole.channels = {"mag2", "gyro"};
  auto w = gap::Diagnose(imp->log, d->vehicle, whole);
  ASSERT_TRUE(w.ok()) << w.status().message();
  const gap::ChannelResult* mag2 = Channel(d->report, "mag2");
  const gap::ChannelResult* gyro = Channel(d->report, "gyro");
  const gap::ChannelResult* mag2_whole = Channel(*w, "mag2");
  const gap::ChannelResult* gyro_whole = Channel(*w, "gyro");
  ASSERT_TRUE(mag2 && gyro && mag2_whole && gyro_whole);
  EXPECT_EQ(mag2->samples, mag2_whole->samples);
  EXPECT_EQ(mag2->verdict, mag2_whole->verdict);
  EXPECT_LT(gyro->samples, 0.7 * gyro_whole->samples);
  ASSERT_TRUE(mag2->absolute_terms.has_value());
  EXPECT_NE(mag2->absolute_terms->held_out.find("every flight block"), std::string::npos);
  EXPECT_NE(d->vehicle_source["how"].get<std::string>().find("compasses on every block"), std::string::npos);
}

TEST(DiagnoseLog, GivenAVehicleThatDoesNotExistThenItIsBadInputNamingIt) {
  LogDiagnosisOptions o;
  o.vehicle = "no_such_vehicle";
  auto d = DiagnoseLog(FramelessLog(), o);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.status().message().find("no_such_vehicle"), std::string::npos);
}

}  // namespace
}  // namespace hexsim::experiments
