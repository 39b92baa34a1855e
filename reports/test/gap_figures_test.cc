// gap.html's figures show a compass in the unit its text uses (mG), every other channel in its own.
#include "../src/gap_figures.h"

#include <gtest/gtest.h>

namespace hexsim::reports {
namespace {

gap::ChannelResult Channel(const std::string& name, const std::string& unit) {
  gap::ChannelResult c;
  c.channel = name;
  c.unit = unit;
  c.t_s = {0.0, 1.0};
  c.residual_before = {Eigen::Vector3d(3.0, 0.0, 4.0), Eigen::Vector3d(0.0, 1.0, 0.0)};
  c.residual_after = {Eigen::Vector3d(0.3, 0.0, 0.4), Eigen::Vector3d(0.0, 0.1, 0.0)};
  return c;
}

TEST(GapFigures, GivenACompassChannelThenEveryFigureIsInMilliGauss) {
  gap::ChannelResult c = Channel("mag2", "uT");
  c.chosen_regressor = {5.0, 20.0};
  c.chosen_regressor_name = "current_A";
  const auto figures = GapChannelFigures(c, {{0.0, 1.0, "hover"}});
  ASSERT_EQ(figures.size(), 3u);
  EXPECT_EQ(figures[0].file, "gap_mag2_time.png");
  EXPECT_EQ(figures[0].plot.y_label, "|residual| (mG)");
  EXPECT_TRUE(figures[0].phase_legend);
  EXPECT_EQ(figures[0].plot.spans.size(), 1u);
  EXPECT_DOUBLE_EQ(figures[0].plot.series[0].y[0], 50.0);  // |(3, 0, 4)| µT = 50 mG
  EXPECT_DOUBLE_EQ(figures[0].plot.series[1].y[0], 5.0);
  EXPECT_EQ(figures[1].plot.y_label, "mG");
  EXPECT_DOUBLE_EQ(figures[1].plot.series[4].y[0], 40.0);  // z before
  EXPECT_EQ(figures[2].plot.y_label, "mG");
  EXPECT_DOUBLE_EQ(figures[2].plot.series[1].y[1], 10.0);  // y before against the regressor
  EXPECT_DOUBLE_EQ(figures[2].plot.series[1].x[1], 20.0);
}

TEST(GapFigures, GivenAGyroChannelThenItsOwnUnitAndNoRegressorFigure) {
  const auto figures = GapChannelFigures(Channel("gyro", "rad/s"), {});
  ASSERT_EQ(figures.size(), 2u);
  EXPECT_EQ(figures[0].plot.y_label, "|residual| (rad/s)");
  EXPECT_DOUBLE_EQ(figures[0].plot.series[0].y[0], 5.0);
  EXPECT_EQ(figures[1].plot.y_label, "rad/s");
}

}  // namespace
}  // namespace hexsim::reports
