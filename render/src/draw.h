// Internal: drawing plots into a rectangle of a Canvas.
#pragma once

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

Result<Layout2D> LayoutPlot2D(Canvas& canvas, const Plot2D& plot, double x0, double y0, double w, double h);
Status DrawPlot2D(Canvas& canvas, const Plot2D& plot, double x0, double y0, double w, double h);
Status DrawPlot3D(Canvas& canvas, const Plot3D& plot, double x0, double y0, double w, double h);

struct LegendEntry {
  std::string label;
  Colour colour;
  SeriesStyle style = SeriesStyle::kLine;
  bool dashed = false;
};
// Draws a legend box in a corner of the area (x0, y0)–(x1, y1).
void DrawLegend(Canvas& canvas, const Style& style, const std::vector<LegendEntry>& entries, LegendPosition where,
                double x0, double y0, double x1, double y1);

}  // namespace hexsim::render::internal
