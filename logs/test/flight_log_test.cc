#include "hexsim/logs/flight_log.h"

#include <gtest/gtest.h>

namespace hexsim::logs {
namespace {

TEST(FlightLog, CsvRoundTripKeepsValuesAndMissingCells) {
  FlightLog log;
  const size_t t = log.AddColumn("t_s");
  const size_t m = log.AddColumn("mag_x_uT");
  for (int i = 0; i < 3; ++i) {
    log.AppendRow();
    log.Set(t, 0.01 * i);
    if (i > 0) log.Set(m, 20.123456789 + i);
  }
  auto back = ParseFlightLogCsv(FlightLogToCsv(log), "mem.csv");
  ASSERT_TRUE(back.ok()) << back.status().message();
  ASSERT_EQ(back->rows(), 3u);
  EXPECT_TRUE(std::isnan(back->Column("mag_x_uT")[0]));
  EXPECT_EQ(back->Column("mag_x_uT")[2], 22.123456789);
  EXPECT_EQ(back->Column("t_s")[1], 0.01);
}

TEST(FlightLog, RejectsMissingTimeColumnAndRaggedRows) {
  EXPECT_EQ(ParseFlightLogCsv("a,b\n1,2\n", "x.csv").status().message(), "x.csv:1: t_s: required column is missing");
  EXPECT_EQ(ParseFlightLogCsv("t_s,b\n1,2\n3\n", "x.csv").status().message(),
            "x.csv:3: row: expected 2 cells, found 1");
  EXPECT_EQ(ParseFlightLogCsv("", "x.csv").status().code(), StatusCode::kBadInput);
  EXPECT_EQ(ParseFlightLogCsv("t_s,b\n1,abc\n", "x.csv").status().message(),
            "x.csv:2: b: not a finite number: 'abc'");
}

TEST(FlightLog, MetaPathReplacesCsvExtension) {
  EXPECT_EQ(MetaPathFor("out/log.csv"), "out/log.meta.json");
}

}  // namespace
}  // namespace hexsim::logs
