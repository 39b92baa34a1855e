// Figure style rules every render follows: lines at most 2 px wide, the legend where no data is.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>

#include "hexsim/render/image.h"
#include "hexsim/render/plot.h"

namespace hexsim::render {
namespace {

const Colour kRed = {1.0f, 0.0f, 0.0f, 1.0f};

Series Line(const std::string& label, std::vector<double> x, std::vector<double> y) {
  Series s;
  s.label = label;
  s.x = std::move(x);
  s.y = std::move(y);
  s.colour = kRed;
  return s;
}

class FigureStyle : public ::testing::Test {
 protected:
  void SetUp() override { ::unsetenv("DISPLAY"); }
};

TEST_F(FigureStyle, GivenAWideSeriesOnALargePanel_WhenRendered_ThenTheLineIsAtMostTwoPixelsThick) {
  // Given: width 5 px requested on a 1500x900 panel (style scale 1.5)
  Plot2D p;
  p.grid = false;
  p.legend = LegendPosition::kNone;
  Series s = Line("", {0.0, 1.0}, {0.5, 0.5});
  s.width_px = 5.0f;
  p.series.push_back(s);
  // When
  auto img = Render(p, 1500, 900);
  ASSERT_TRUE(img.ok()) << img.status().message();
  auto layout = ComputeLayout(p, 1500, 900);
  ASSERT_TRUE(layout.ok());
  // Then: the ink across the line in one column adds up to at most 2 px (anti-aliased edges included)
  const int x = static_cast<int>(0.5 * (layout->left_px + layout->right_px));
  double ink_px = 0.0;
  for (int y = static_cast<int>(layout->top_px) + 2; y < static_cast<int>(layout->bottom_px) - 2; ++y) {
    ink_px += 1.0 - img->At(x, y).g / 255.0;
  }
  EXPECT_GT(ink_px, 1.0);
  EXPECT_LE(ink_px, 2.15);
}

TEST_F(FigureStyle, GivenDataThroughTheRequestedCorner_WhenRendered_ThenTheLegendMovesToAnEmptyCorner) {
  // Given: a diagonal from bottom-left to top-right, legend asked for top right
  Plot2D p;
  p.legend = LegendPosition::kTopRight;
  std::vector<double> x, y;
  for (int i = 0; i <= 100; ++i) {
    x.push_back(i / 100.0);
    y.push_back(i / 100.0);
  }
  p.series.push_back(Line("diagonal", x, y));
  // When
  auto box = ComputeLegendBox(p, 800, 600);
  auto layout = ComputeLayout(p, 800, 600);
  // Then: top left (the first empty corner after the requested one), inside the plot area
  ASSERT_TRUE(box.ok() && layout.ok());
  ASSERT_TRUE(box->has_value());
  const LegendBox& b = **box;
  EXPECT_FALSE(b.outside);
  EXPECT_LT(b.x_px, 0.5 * (layout->left_px + layout->right_px));
  EXPECT_LT(b.y_px, 0.5 * (layout->top_px + layout->bottom_px));
}

TEST_F(FigureStyle, GivenDataInEveryCorner_WhenRendered_ThenTheLegendIsOutsideThePlotArea) {
  // Given: both diagonals (a cross through all four corners)
  Plot2D p;
  p.legend = LegendPosition::kBottomRight;
  p.series.push_back(Line("rising", {0.0, 1.0}, {0.0, 1.0}));
  p.series.push_back(Line("falling", {0.0, 1.0}, {1.0, 0.0}));
  // When
  auto box = ComputeLegendBox(p, 800, 600);
  auto img = Render(p, 800, 600);
  // Then: right of the (narrowed) plot area, inside the image
  ASSERT_TRUE(box.ok() && img.ok());
  ASSERT_TRUE(box->has_value());
  const LegendBox& b = **box;
  EXPECT_TRUE(b.outside);
  EXPECT_LE(b.x_px + b.width_px, 800.0);
  auto full = ComputeLayout(p, 800, 600);
  ASSERT_TRUE(full.ok());
  EXPECT_GT(b.x_px + b.width_px, full->right_px - 1.0);
}

TEST_F(FigureStyle, GivenAPlotWithoutLabels_WhenAskedForTheLegend_ThenThereIsNone) {
  Plot2D p;
  p.series.push_back(Line("", {0.0, 1.0}, {0.0, 1.0}));
  auto box = ComputeLegendBox(p, 400, 300);
  ASSERT_TRUE(box.ok());
  EXPECT_FALSE(box->has_value());
}

}  // namespace
}  // namespace hexsim::render
