#include "hexsim/logs/mag_input.h"

#include <fstream>

#include <gtest/gtest.h>

namespace hexsim::logs {
namespace {

using Eigen::Vector3d;

TEST(MagInput, GivenPlainWhitespaceWithoutHeader_WhenParsed_ThenThreeColumnsAreXyzInUnknownUnits) {
  auto in = ParseMagInput("# a serial dump\n1 2 3\n4.5\t5 -6\n\n7e1 8 9\n", "dump.txt", "mag");
  ASSERT_TRUE(in.ok()) << in.status().message();
  EXPECT_EQ(in->format, "xyz");
  EXPECT_EQ(in->units, "");
  ASSERT_EQ(in->field.size(), 3u);
  EXPECT_EQ(in->field[2], Vector3d(70, 8, 9));
  EXPECT_TRUE(in->control_u.empty());
}

TEST(MagInput, GivenHeaderNamingTheAxes_WhenParsed_ThenThoseColumnsAreRead) {
  for (const char* text : {"t,MagX,MagY,MagZ\n0,1,2,3\n1,4,5,6\n", "time\tx_raw\ty_raw\tz_raw\n0\t1\t2\t3\n1\t4\t5\t6\n",
                           "mx my mz\n1 2 3\n4 5 6\n"}) {
    auto in = ParseMagInput(text, "dump.csv", "mag");
    ASSERT_TRUE(in.ok()) << text << in.status().message();
    ASSERT_EQ(in->field.size(), 2u) << text;
    EXPECT_EQ(in->field[1], Vector3d(4, 5, 6)) << text;
  }
}

TEST(MagInput, GivenFlightLogCsv_WhenParsed_ThenOneSamplePerNewCompassTimeInMicrotesla) {
  const std::string text =
      "t_s,control_u,mag2_t_s,mag2_x_uT,mag2_y_uT,mag2_z_uT\n"
      "0.00,10,,,,\n0.01,11,0.005,20,1,40\n0.02,12,0.005,20,1,40\n0.03,13,0.025,21,2,41\n";
  auto in = ParseMagInput(text, "log.csv", "mag2");
  ASSERT_TRUE(in.ok()) << in.status().message();
  EXPECT_EQ(in->format, "flightlog");
  EXPECT_EQ(in->units, "uT");
  ASSERT_EQ(in->field.size(), 2u);
  EXPECT_EQ(in->control_u, (std::vector<double>{11, 13}));
  EXPECT_FALSE(ParseMagInput(text, "log.csv", "mag").ok());
}

TEST(MagInput, GivenAnArduPilotMeta_WhenParsed_ThenTheRawFieldIsRebuilt) {
  // logged = M·(raw + OFS) + MOT, OFS in mG; raw = (10, 20, 30) µT.
  const nlohmann::json meta = {{"format", "ardupilot-dataflash"},
                               {"compasses",
                                {{{"column", "mag"},
                                  {"offsets_mG", {100.0, -50.0, 0.0}},
                                  {"diagonals", {1.0, 2.0, 1.0}},
                                  {"offdiagonals", {0.0, 0.0, 0.0}},
                                  {"scale", nullptr}}}}};
  const std::string text = "t_s,mag_t_s,mag_x_uT,mag_y_uT,mag_z_uT,mag_mot_x_uT,mag_mot_y_uT,mag_mot_z_uT\n0,0,21,32,31,1,2,1\n";
  auto in = ParseMagInput(text, "log.csv", "mag", meta);
  ASSERT_TRUE(in.ok()) << in.status().message();
  ASSERT_EQ(in->field.size(), 1u);
  EXPECT_TRUE(in->field[0].isApprox(Vector3d(10, 20, 30), 1e-12)) << in->field[0].transpose();
  EXPECT_TRUE(in->prior_offset.isApprox(Vector3d(-10, 5, 0), 1e-12));  // b = −OFS
}

TEST(MagInput, GivenBadInput_WhenParsed_ThenBadInputNamingFileAndLine) {
  auto ragged = ParseMagInput("1 2 3\n4 5\n", "dump.txt", "mag");
  ASSERT_FALSE(ragged.ok());
  EXPECT_NE(ragged.status().message().find("dump.txt:2"), std::string::npos) << ragged.status().message();
  auto word = ParseMagInput("x,y,z\n1,2,3\n4,five,6\n", "d.csv", "mag");
  ASSERT_FALSE(word.ok());
  EXPECT_NE(word.status().message().find("d.csv:3: y"), std::string::npos) << word.status().message();
  EXPECT_EQ(ParseMagInput("", "e.txt", "mag").status().code(), StatusCode::kBadInput);
  EXPECT_EQ(ParseMagInput("a,b,c\n1,2,3\n", "n.csv", "mag").status().code(), StatusCode::kBadInput);
  EXPECT_EQ(ParseMagInput(std::string("ULog\x01\x12\x35", 7), "f.ulg", "mag").status().code(), StatusCode::kBadInput);
  EXPECT_EQ(ParseMagInput("1 2 3\n", "d.txt", "compass").status().code(), StatusCode::kBadInput);
  EXPECT_EQ(CompassIndex("mag3"), 2);
}

}  // namespace
}  // namespace hexsim::logs

namespace hexsim::logs {
namespace {

// A FlightLog CSV is read once and kept for the flight path; a compass it lacks is named.
TEST(MagInput, GivenAFlightLogCsvFile_WhenRead_ThenTheLogIsKeptAndAMissingCompassIsNamed) {
  const std::string path = ::testing::TempDir() + "/mag_input_flightlog.csv";
  {
    std::ofstream f(path);
    f << "t_s,mag_x_uT,mag_y_uT,mag_z_uT\n0,20,1,-40\n0.1,21,1,-40\n0.2,22,1,-40\n";
  }
  auto in = ReadMagInput(path, "mag");
  ASSERT_TRUE(in.ok()) << in.status().message();
  EXPECT_EQ(in->format, "flightlog");
  ASSERT_NE(in->log, nullptr);
  EXPECT_EQ(in->log->rows(), 3u);
  EXPECT_EQ(in->field.size(), 3u);
  auto missing = ReadMagInput(path, "mag3");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.status().message().find("mag3: the log has no such compass"), std::string::npos)
      << missing.status().message();
}

}  // namespace
}  // namespace hexsim::logs
