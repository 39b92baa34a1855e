// Internal: drawing plots into a rectangle of a Canvas.
#pragma once

#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include "canvas.h"
#include "hexsim/render/plot.h"

namespace hexsim::render::internal {

// Font sizes and spacing for a panel of the given size (logical px).
struct Style {
  double scale = 1.0;
  double title_px() const { return 15.0 * scale; }
  double label_px() const { return 13.0 * scale; }
  double tick_px() const { return 11.5 * scale; }
  double legend_px() const { return 11.5 * scale; }
  double pad_px() const { return 8.0 * scale; }
  static Style ForPanel(double width_px, double height_px);
};

inline const Colour kInk = {0.13f, 0.13f, 0.13f, 1.0f};       // text, frame
inline const Colour kGrid = {0.86f, 0.86f, 0.86f, 1.0f};      // grid lines
inline const Colour kMuted = {0.35f, 0.35f, 0.35f, 1.0f};     // secondary text

// The layout with the legend placed (PlacePlot2D: the requested corner if no data enters it, else
// another empty corner, else outside on the right with the plot narrowed).
struct Placed2D {
  Layout2D layout;
  std::optional<LegendBox> legend;
};
Result<Placed2D> PlacePlot2D(Canvas& canvas, const Plot2D& plot, double x0, double y0, double w, double h);
Result<Layout2D> LayoutPlot2D(Canvas& canvas, const Plot2D& plot, double x0, double y0, double w, double h);
Status DrawPlot2D(Canvas& canvas, const Plot2D& plot, double x0, double y0, double w, double h);
Status DrawPlot3D(Canvas& canvas, const Plot3D& plot, double x0, double y0, double w, double h);

struct LegendEntry {
  std::string label;
  Colour colour;
  SeriesStyle style = SeriesStyle::kLine;
  bool dashed = false;
};
// Lines are at most this wide at any panel size (figures stay readable where series coincide).
inline constexpr double kMaxLineWidth_px = 2.0;
// A series' line width at this panel's scale, capped at kMaxLineWidth_px.
inline double LineWidth(double width_px, const Style& st) { return std::min(width_px * st.scale, kMaxLineWidth_px); }

// Legend box size (width, height) for these entries, and its top-left corner at `where` in the
// area (x0, y0)–(x1, y1).
Pt LegendSize(Canvas& canvas, const Style& st, const std::vector<LegendEntry>& entries);
Pt LegendCorner(const Style& st, const Pt& size, LegendPosition where, double x0, double y0, double x1, double y1);
// Draws the legend box with its top-left corner at (bx, by).
void DrawLegendAt(Canvas& canvas, const Style& st, const std::vector<LegendEntry>& entries, double bx, double by);
// Draws a legend box in a corner of the area (x0, y0)–(x1, y1).
void DrawLegend(Canvas& canvas, const Style& style, const std::vector<LegendEntry>& entries, LegendPosition where,
                double x0, double y0, double x1, double y1);

}  // namespace hexsim::render::internal
