// Pixel-level tests of the off-screen plotting layer.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <tuple>

#include "hexsim/common/atomic_file.h"
#include "hexsim/render/image.h"
#include "hexsim/render/plot.h"

namespace hexsim::render {
namespace {

namespace fs = std::filesystem;

bool IsRed(Rgba8 p) { return p.r > 180 && p.g < 90 && p.b < 90; }
bool IsDark(Rgba8 p) { return p.r < 110 && p.g < 110 && p.b < 110; }
bool IsWhite(Rgba8 p) { return p.r > 245 && p.g > 245 && p.b > 245; }

int CountIn(const Image& img, double x0, double y0, double x1, double y1, bool (*pred)(Rgba8)) {
  int n = 0;
  for (int y = std::max(0, static_cast<int>(std::floor(y0))); y <= std::min(img.height - 1, static_cast<int>(y1)); ++y) {
    for (int x = std::max(0, static_cast<int>(std::floor(x0))); x <= std::min(img.width - 1, static_cast<int>(x1)); ++x) {
      if (pred(img.At(x, y))) ++n;
    }
  }
  return n;
}

class RenderTest : public ::testing::Test {
 protected:
  // Every render must work with no X server: no DISPLAY at all.
  void SetUp() override { ::unsetenv("DISPLAY"); }
};

const Colour kRed = {1.0f, 0.0f, 0.0f, 1.0f};

// y = x for x in [0, 0.5] on fixed [0, 1] × [0, 1] axes.
Plot2D HalfDiagonal() {
  Plot2D p;
  p.title = "Diagonal";
  p.x_label = "x (m)";
  p.y_label = "y (m)";
  p.x_range = Range{0.0, 1.0};
  p.y_range = Range{0.0, 1.0};
  p.legend = LegendPosition::kNone;
  Series s;
  for (int i = 0; i <= 50; ++i) {
    s.x.push_back(0.01 * i);
    s.y.push_back(0.01 * i);
  }
  s.colour = kRed;
  s.width_px = 3.0f;
  p.series.push_back(s);
  return p;
}

TEST_F(RenderTest, GivenFixedRangesWhenASeriesIsPlottedThenItsColourAppearsOnlyWhereTheDataMaps) {
  const Plot2D plot = HalfDiagonal();
  Result<Image> img = Render(plot, 400, 300);
  ASSERT_TRUE(img.ok()) << img.status().message();
  ASSERT_EQ(img->width, 400);
  ASSERT_EQ(img->height, 300);
  Result<Layout2D> L = ComputeLayout(plot, 400, 300);
  ASSERT_TRUE(L.ok());
  // On the curve: a red pixel within 2 px of each sampled data point.
  for (double v : {0.05, 0.15, 0.25, 0.35, 0.45}) {
    const double px = L->XToPx(v), py = L->YToPx(v);
    EXPECT_GT(CountIn(*img, px - 2, py - 2, px + 2, py + 2, IsRed), 0) << "no curve at x = " << v;
  }
  // Nowhere right of x = 0.55 (the data stops at 0.5; the line is 3 px wide).
  EXPECT_EQ(CountIn(*img, L->XToPx(0.55), 0, img->width - 1, img->height - 1, IsRed), 0);
  // Not far above or below the diagonal: y − x ≥ 0.1 or ≤ −0.1 holds no red.
  int off_curve = 0;
  for (int y = static_cast<int>(L->top_px) + 2; y < static_cast<int>(L->bottom_px) - 2; ++y) {
    for (int x = static_cast<int>(L->left_px) + 2; x < static_cast<int>(L->XToPx(0.5)); ++x) {
      const double dx = L->x.lo + (x - L->left_px) / (L->right_px - L->left_px) * (L->x.hi - L->x.lo);
      const double dy = L->y.lo + (L->bottom_px - y) / (L->bottom_px - L->top_px) * (L->y.hi - L->y.lo);
      if (std::fabs(dy - dx) > 0.1 && IsRed(img->At(x, y))) ++off_curve;
    }
  }
  EXPECT_EQ(off_curve, 0);
}

TEST_F(RenderTest, GivenAPlotThenFrameTickLabelsAndTitleAreDrawnInDarkInk) {
  const Plot2D plot = HalfDiagonal();
  Result<Image> img = Render(plot, 400, 300);
  ASSERT_TRUE(img.ok());
  Result<Layout2D> L = ComputeLayout(plot, 400, 300);
  ASSERT_TRUE(L.ok());
  // Plot area is inside the image and takes most of it.
  EXPECT_GT(L->left_px, 0);
  EXPECT_GT(L->top_px, 0);
  EXPECT_LT(L->right_px, 400);
  EXPECT_LT(L->bottom_px, 300);
  EXPECT_GT((L->right_px - L->left_px) * (L->bottom_px - L->top_px), 0.5 * 400 * 300);
  // Frame: the left and bottom edges are dark along their length.
  const double ym = 0.5 * (L->top_px + L->bottom_px), xm = 0.5 * (L->left_px + L->right_px);
  EXPECT_GT(CountIn(*img, L->left_px - 1, ym - 1, L->left_px + 1, ym + 1, IsDark), 0);
  EXPECT_GT(CountIn(*img, xm - 1, L->bottom_px - 1, xm + 1, L->bottom_px + 1, IsDark), 0);
  // Ticks on [0, 1]: nice values, and a label (dark glyph pixels) under each x tick, left of each y tick.
  ASSERT_GE(L->x_ticks.size(), 3u);
  ASSERT_GE(L->y_ticks.size(), 3u);
  for (double t : L->x_ticks) {
    const double px = L->XToPx(t);
    EXPECT_GT(CountIn(*img, px - 8, L->bottom_px + 6, px + 8, L->bottom_px + 22, IsDark), 3) << "x tick " << t;
  }
  for (double t : L->y_ticks) {
    const double py = L->YToPx(t);
    EXPECT_GT(CountIn(*img, L->left_px - 40, py - 5, L->left_px - 6, py + 5, IsDark), 3) << "y tick " << t;
  }
  EXPECT_GT(CountIn(*img, 0, 0, 400, L->top_px - 4, IsDark), 20);  // title
}

TEST_F(RenderTest, GivenNaNValuesThenTheLineHasAGapThere) {
  Plot2D p;
  p.x_range = Range{0.0, 1.0};
  p.y_range = Range{0.0, 1.0};
  p.grid = false;
  Series s;
  for (int i = 0; i <= 100; ++i) {
    const double x = 0.01 * i;
    s.x.push_back(x);
    s.y.push_back(x > 0.4 && x < 0.6 ? std::nan("") : 0.5);
  }
  s.colour = kRed;
  p.series.push_back(s);
  p.legend = LegendPosition::kNone;
  Result<Image> img = Render(p, 300, 200);
  ASSERT_TRUE(img.ok());
  Result<Layout2D> L = ComputeLayout(p, 300, 200);
  ASSERT_TRUE(L.ok());
  const double py = L->YToPx(0.5);
  EXPECT_GT(CountIn(*img, L->XToPx(0.2) - 1, py - 2, L->XToPx(0.2) + 1, py + 2, IsRed), 0);
  EXPECT_GT(CountIn(*img, L->XToPx(0.8) - 1, py - 2, L->XToPx(0.8) + 1, py + 2, IsRed), 0);
  EXPECT_EQ(CountIn(*img, L->XToPx(0.45), py - 3, L->XToPx(0.55), py + 3, IsRed), 0);
}

TEST_F(RenderTest, GivenEqualAspectThenOneDataUnitSpansTheSamePixelsOnBothAxes) {
  Plot2D p;
  p.equal_aspect = true;
  Series s;
  s.x = {0.0, 100.0};
  s.y = {0.0, 10.0};
  p.series.push_back(s);
  Result<Layout2D> L = ComputeLayout(p, 500, 300);
  ASSERT_TRUE(L.ok());
  const double sx = (L->right_px - L->left_px) / (L->x.hi - L->x.lo);
  const double sy = (L->bottom_px - L->top_px) / (L->y.hi - L->y.lo);
  EXPECT_NEAR(sx / sy, 1.0, 1e-9);
  EXPECT_LE(L->x.lo, 0.0);
  EXPECT_GE(L->x.hi, 100.0);
}

TEST_F(RenderTest, GivenALegendThenItsLabelTextIsDrawnInTheChosenCorner) {
  Plot2D p = HalfDiagonal();
  p.series[0].label = "measured heading";
  p.legend = LegendPosition::kBottomRight;
  Result<Image> img = Render(p, 400, 300);
  ASSERT_TRUE(img.ok());
  Result<Layout2D> L = ComputeLayout(p, 400, 300);
  ASSERT_TRUE(L.ok());
  const double xm = 0.5 * (L->left_px + L->right_px), ym = 0.5 * (L->top_px + L->bottom_px);
  // Legend text (dark) in the bottom-right quarter of the plot area, none in the top-right quarter.
  EXPECT_GT(CountIn(*img, xm, ym, L->right_px - 3, L->bottom_px - 3, IsDark), 30);
  EXPECT_EQ(CountIn(*img, xm, L->top_px + 3, L->right_px - 3, ym, IsDark), 0);
}

TEST_F(RenderTest, GivenA3DHelixThenTheImageHoldsItsColourAndAxisText) {
  Plot3D p;
  p.title = "Helix";
  p.x_label = "x (m)";
  p.y_label = "y (m)";
  p.z_label = "z (m)";
  Series3D s;
  for (int i = 0; i <= 300; ++i) {
    const double a = 0.05 * i;
    s.x.push_back(std::cos(a));
    s.y.push_back(std::sin(a));
    s.z.push_back(0.1 * a);
  }
  s.colour = kRed;
  s.width_px = 2.5f;
  p.series.push_back(s);
  Ellipsoid3D e;
  e.centre = {0.0, 0.0, 0.75};
  e.shape = {{{0.5, 0.0, 0.0}, {0.0, 0.5, 0.0}, {0.0, 0.0, 0.5}}};
  p.ellipsoids.push_back(e);
  Result<Image> img = Render(p, 360, 320);
  ASSERT_TRUE(img.ok()) << img.status().message();
  EXPECT_GT(CountIn(*img, 0, 0, 359, 319, IsRed), 200);
  EXPECT_GT(CountIn(*img, 0, 0, 359, 319, IsDark), 100);
  EXPECT_LT(CountIn(*img, 0, 0, 359, 319, IsWhite), 360 * 320);
}

TEST_F(RenderTest, GivenSeveralRendersInSequenceThenEachHasItsSizeAndTheSameInputGivesTheSamePixels) {
  const Plot2D plot = HalfDiagonal();
  Result<Image> a = Render(plot, 320, 240);
  Result<Image> b = Render(plot, 200, 150);
  Result<Image> c = Render(plot, 320, 240);
  ASSERT_TRUE(a.ok() && b.ok() && c.ok());
  EXPECT_EQ(b->width, 200);
  EXPECT_EQ(b->height, 150);
  EXPECT_EQ(a->rgba, c->rgba);
}

TEST_F(RenderTest, GivenAFigureThenEachPanelIsDrawnInItsCell) {
  Figure f;
  f.rows = 1;
  f.cols = 2;
  Plot2D left = HalfDiagonal();
  Plot2D right = HalfDiagonal();
  right.series[0].colour = Colour{0.0f, 0.0f, 1.0f, 1.0f};
  f.panels = {left, right};
  Result<Image> img = Render(f, 600, 250);
  ASSERT_TRUE(img.ok());
  auto is_blue = [](Rgba8 p) { return p.b > 180 && p.r < 90 && p.g < 90; };
  EXPECT_GT(CountIn(*img, 0, 0, 299, 249, IsRed), 20);
  EXPECT_EQ(CountIn(*img, 300, 0, 599, 249, IsRed), 0);
  EXPECT_GT(CountIn(*img, 300, 0, 599, 249, is_blue), 20);
  EXPECT_EQ(CountIn(*img, 0, 0, 299, 249, is_blue), 0);
}

TEST_F(RenderTest, GivenBadInputThenRenderSaysSoInsteadOfDrawing) {
  Plot2D p;
  Series s;
  s.label = "bad";
  s.x = {0.0, 1.0};
  s.y = {0.0};
  p.series.push_back(s);
  EXPECT_EQ(Render(p, 200, 200).status().code(), StatusCode::kBadInput);
  EXPECT_EQ(Render(HalfDiagonal(), 4, 4).status().code(), StatusCode::kBadInput);
  Plot2D q = HalfDiagonal();
  q.x_range = Range{1.0, 1.0};
  EXPECT_EQ(Render(q, 200, 200).status().code(), StatusCode::kBadInput);
}

TEST(NiceTicksTest, GivenARangeThenTicksAreRoundStepsInsideIt) {
  const std::vector<double> t = NiceTicks(0.0, 10.0, 5);
  ASSERT_EQ(t.size(), 6u);
  for (size_t i = 0; i < t.size(); ++i) EXPECT_DOUBLE_EQ(t[i], 2.0 * i);
  for (auto [lo, hi, n] : {std::tuple{-3.7, 12.1, 6}, {0.0012, 0.0047, 4}, {-180.0, 180.0, 8}, {1e5, 3.2e5, 5}}) {
    const std::vector<double> v = NiceTicks(lo, hi, n);
    ASSERT_GE(v.size(), 2u);
    EXPECT_LE(v.size(), static_cast<size_t>(2 * n + 1));
    const double step = v[1] - v[0];
    const double mantissa = step / std::pow(10.0, std::floor(std::log10(step) + 1e-9));
    EXPECT_TRUE(std::fabs(mantissa - 1) < 1e-6 || std::fabs(mantissa - 2) < 1e-6 || std::fabs(mantissa - 2.5) < 1e-6 ||
                std::fabs(mantissa - 5) < 1e-6)
        << step;
    EXPECT_GE(v.front(), lo - 1e-12);
    EXPECT_LE(v.back(), hi + 1e-12);
  }
}

TEST(NiceTicksTest, GivenTickValuesThenLabelsHaveJustEnoughDecimalsAndNoNegativeZero) {
  EXPECT_EQ(FormatTick(2.5, 2.5), "2.5");
  EXPECT_EQ(FormatTick(10.0, 5.0), "10");
  EXPECT_EQ(FormatTick(50.0, 25.0), "50");
  EXPECT_EQ(FormatTick(0.75, 0.25), "0.75");
  EXPECT_EQ(FormatTick(0.2, 0.1), "0.2");
  EXPECT_EQ(FormatTick(-0.0, 0.5), "0.0");
  EXPECT_EQ(FormatTick(-1e-17, 0.5), "0.0");
  EXPECT_EQ(FormatTick(-30.0, 10.0), "\u221230");
}

TEST(PngTest, GivenAnImageWhenWrittenAndReadBackThenEveryPixelMatchesAndNoTemporaryIsLeft) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("render_png_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  Image img(37, 21);
  for (int y = 0; y < img.height; ++y) {
    for (int x = 0; x < img.width; ++x) {
      img.Set(x, y, {static_cast<uint8_t>(x * 7), static_cast<uint8_t>(y * 12), static_cast<uint8_t>(x ^ y),
                     static_cast<uint8_t>(255 - x)});
    }
  }
  const std::string path = (dir / "round.png").string();
  ASSERT_TRUE(WritePng(img, path).ok());
  Result<Image> back = ReadPng(path);
  ASSERT_TRUE(back.ok()) << back.status().message();
  EXPECT_EQ(back->width, 37);
  EXPECT_EQ(back->height, 21);
  EXPECT_EQ(back->rgba, img.rgba);
  size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    (void)entry;
    ++files;
  }
  EXPECT_EQ(files, 1u);
  // Not a PNG: bad input, naming the file.
  ASSERT_TRUE(WriteFileAtomic((dir / "fake.png").string(), "hello").ok());
  Result<Image> fake = ReadPng((dir / "fake.png").string());
  EXPECT_EQ(fake.status().code(), StatusCode::kBadInput);
  EXPECT_NE(fake.status().message().find("fake.png"), std::string::npos);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace hexsim::render
