// A small plotting layer drawn with OpenGL into an off-screen OSMesa buffer (no display needed).
//
// Describe a plot as plain data (Plot2D, Plot3D, Figure), then Render(...) it to an Image.
// Non-finite values (NaN, inf) in a series are gaps. Text is DejaVu Sans rasterised by FreeType.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "hexsim/common/status.h"
#include "hexsim/render/image.h"

namespace hexsim::render {

struct Colour {
  float r = 0.0f, g = 0.0f, b = 0.0f, a = 1.0f;  // each 0..1
};
// "#rrggbb" -> Colour (aborts on a malformed literal: for constants only).
Colour Hex(const char* rrggbb, float alpha = 1.0f);
// The i-th colour of the default palette (Tableau 10: distinguishable, colour-blind aware), cycling.
Colour PaletteColour(size_t index);

enum class SeriesStyle { kLine, kScatter, kLineMarkers };
enum class LegendPosition { kNone, kTopRight, kTopLeft, kBottomRight, kBottomLeft };

struct Series {
  std::string label;            // empty: not listed in the legend
  std::vector<double> x, y;     // same length; non-finite values are gaps
  std::optional<Colour> colour; // unset: next palette colour
  SeriesStyle style = SeriesStyle::kLine;
  float width_px = 1.6f;        // line width
  float marker_px = 4.0f;       // marker diameter
  bool dashed = false;
};

struct Range {
  double lo = 0.0, hi = 1.0;
};

// A shaded band lo_x..hi_x over the full plot height (e.g. a flight phase).
struct XSpan {
  double lo = 0.0, hi = 0.0;
  std::string label;  // drawn at the top of the band
  Colour colour = {0.5f, 0.5f, 0.5f, 0.12f};
};

// A dashed reference line: horizontal at `value` (y) or vertical (x).
struct RefLine {
  enum class Axis { kHorizontal, kVertical };
  Axis axis = Axis::kHorizontal;
  double value = 0.0;
  std::string label;
  Colour colour = {0.25f, 0.25f, 0.25f, 1.0f};
};

struct Plot2D {
  std::string title, x_label, y_label;
  std::vector<Series> series;
  std::optional<Range> x_range, y_range;  // unset: data range plus a small margin
  LegendPosition legend = LegendPosition::kTopRight;
  bool grid = true;
  bool equal_aspect = false;  // one data unit is as long on x as on y (top-view tracks)
  std::vector<XSpan> spans;
  std::vector<RefLine> ref_lines;
};

using Point3 = std::array<double, 3>;

struct Series3D {
  std::string label;
  std::vector<double> x, y, z;  // non-finite values are gaps
  std::optional<Colour> colour;
  SeriesStyle style = SeriesStyle::kLine;
  float width_px = 1.6f;
  float marker_px = 3.0f;
};

// The ellipsoid {centre + shape·u : |u| = 1}, drawn as a wireframe.
struct Ellipsoid3D {
  Point3 centre = {0.0, 0.0, 0.0};
  std::array<Point3, 3> shape = {{{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}}};  // rows
  std::string label;
  std::optional<Colour> colour;
};

struct Plot3D {
  std::string title, x_label, y_label, z_label;
  std::vector<Series3D> series;
  std::vector<Ellipsoid3D> ellipsoids;
  std::optional<Range> x_range, y_range, z_range;
  double azimuth_deg = -60.0;   // camera about +z, from +x towards +y
  double elevation_deg = 25.0;  // camera above the x-y plane
  bool equal_aspect = false;    // false: the box is a cube whatever the data ranges
  LegendPosition legend = LegendPosition::kTopRight;
};

// A grid of panels, filled row by row; `title` above them all.
struct Figure {
  std::string title;
  int rows = 1, cols = 1;
  std::vector<std::variant<Plot2D, Plot3D>> panels;
};

// Where the plot area and axes of a Plot2D end up in an image of a given size (pixels, y down).
struct Layout2D {
  double left_px = 0, top_px = 0, right_px = 0, bottom_px = 0;  // plot area
  Range x, y;                                                   // data ranges shown
  std::vector<double> x_ticks, y_ticks;
  double XToPx(double x_data) const { return left_px + (x_data - x.lo) / (x.hi - x.lo) * (right_px - left_px); }
  double YToPx(double y_data) const { return bottom_px - (y_data - y.lo) / (y.hi - y.lo) * (bottom_px - top_px); }
};

// Computes the layout Render() uses for `plot` in a `width`×`height` panel at (0, 0).
Result<Layout2D> ComputeLayout(const Plot2D& plot, int width, int height);

// Where Render() puts a Plot2D's legend (pixels, y down): in the requested corner when no series or
// reference line enters it, else in another corner no data enters, else outside the plot area on the
// right (`outside`; the plot is narrowed to make room). Nothing when the plot shows no legend.
struct LegendBox {
  double x_px = 0, y_px = 0, width_px = 0, height_px = 0;  // top-left corner and size
  bool outside = false;
};
Result<std::optional<LegendBox>> ComputeLegendBox(const Plot2D& plot, int width, int height);

// Renders to an image (white background). Sizes in pixels, each 16..8192.
Result<Image> Render(const Plot2D& plot, int width, int height);
Result<Image> Render(const Plot3D& plot, int width, int height);
Result<Image> Render(const Figure& figure, int width, int height);

// "Nice" tick values (steps of 1, 2, 2.5 or 5 × 10^k) inside [lo, hi], about `target` of them.
std::vector<double> NiceTicks(double lo, double hi, int target);
// Tick label text with just enough decimals for `step`.
std::string FormatTick(double value, double step);

}  // namespace hexsim::render
