#include "hexsim/experiments/log_diagnosis.h"

#include <gtest/gtest.h>

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
  EXPECT_EQ(d.status().message(), "flight.csv: frame: not determined (not determined); give --sim VEHICLE");
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

TEST(DiagnoseLog, GivenAVehicleThatDoesNotExistThenItIsBadInputNamingIt) {
  LogDiagnosisOptions o;
  o.vehicle = "no_such_vehicle";
  auto d = DiagnoseLog(FramelessLog(), o);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.status().message().find("no_such_vehicle"), std::string::npos);
}

}  // namespace
}  // namespace hexsim::experiments
