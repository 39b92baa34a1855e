#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <optional>
#include <utility>

#include "draw.h"

namespace hexsim::render {

Colour Hex(const char* rrggbb, float alpha) {
  HEXSIM_CHECK(rrggbb != nullptr && rrggbb[0] == '#');
  const unsigned long v = std::strtoul(rrggbb + 1, nullptr, 16);
  return {static_cast<float>((v >> 16) & 0xFF) / 255.0f, static_cast<float>((v >> 8) & 0xFF) / 255.0f,
          static_cast<float>(v & 0xFF) / 255.0f, alpha};
}

Colour PaletteColour(size_t index) {
  static const char* const kTableau10[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                                           "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};
  return Hex(kTableau10[index % 10]);
}

std::vector<double> NiceTicks(double lo, double hi, int target) {
  std::vector<double> ticks;
  if (!(std::isfinite(lo) && std::isfinite(hi)) || hi <= lo) return ticks;
  target = std::max(target, 1);
  const double raw = (hi - lo) / target;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = 10.0 * mag;
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0}) {
    if (m * mag >= raw * 0.999) {
      step = m * mag;
      break;
    }
  }
  const double eps = step * 1e-9;
  for (double k = std::ceil((lo - eps) / step); k * step <= hi + eps; k += 1.0) {
    double v = k * step;
    if (std::fabs(v) < eps) v = 0.0;
    ticks.push_back(v);
    if (ticks.size() > 100) break;
  }
  return ticks;
}

std::string FormatTick(double value, double step) {
  char buf[64];
  const double big = std::max(std::fabs(value), std::fabs(step));
  if (big >= 1e6 || (step > 0 && step < 1e-4)) {
    std::snprintf(buf, sizeof buf, "%.3g", value);
  } else {
    int decimals = 0;
    if (step > 0) {
      decimals = std::max(0, -static_cast<int>(std::floor(std::log10(step) + 1e-9)));
      const double mantissa = step / std::pow(10.0, std::floor(std::log10(step) + 1e-9));
      if (std::fabs(mantissa - 2.5) < 1e-6 && step < 10.0) ++decimals;  // 0.25, 2.5; not 25
    }
    std::snprintf(buf, sizeof buf, "%.*f", decimals, value);
  }
  std::string s = buf;
  bool all_zero = true;
  for (char c : s) {
    if (c != '-' && c != '0' && c != '.') all_zero = false;
  }
  if (all_zero && !s.empty() && s[0] == '-') s.erase(0, 1);  // no "-0"
  if (!s.empty() && s[0] == '-') s = "\u2212" + s.substr(1);  // typographic minus
  return s;
}

namespace internal {

Style Style::ForPanel(double width_px, double height_px) {
  Style s;
  s.scale = std::clamp(std::sqrt(width_px * height_px) / 560.0, 0.8, 1.5);
  return s;
}

namespace {

void Extend(double v, double* lo, double* hi) {
  if (!std::isfinite(v)) return;
  *lo = std::min(*lo, v);
  *hi = std::max(*hi, v);
}

Range Finish(double lo, double hi) {
  if (!(lo <= hi)) return {0.0, 1.0};
  if (hi - lo < 1e-12 * std::max(1.0, std::fabs(lo))) {
    const double half = std::max(std::fabs(lo) * 0.05, 0.5);
    return {lo - half, hi + half};
  }
  const double margin = 0.04 * (hi - lo);
  return {lo - margin, hi + margin};
}

Status CheckRange(const std::optional<Range>& r, const char* name) {
  if (r && !(std::isfinite(r->lo) && std::isfinite(r->hi) && r->hi > r->lo)) {
    return Status::BadInput(std::string("render: ") + name + ": range must be finite with hi > lo");
  }
  return Status::Ok();
}

double Snap(double v) { return std::floor(v) + 0.5; }

std::vector<Pt> SeriesPixels(const Series& s, const Layout2D& L) {
  std::vector<Pt> pts(s.x.size());
  for (size_t i = 0; i < s.x.size(); ++i) {
    const bool finite = std::isfinite(s.x[i]) && std::isfinite(s.y[i]);
    pts[i] = finite ? Pt{L.XToPx(s.x[i]), L.YToPx(s.y[i])} : Pt{NAN, NAN};
  }
  return pts;
}

// Whether the segment a-b meets the rectangle [x0, x1] × [y0, y1] (Liang–Barsky clipping: the
// segment a + t (b − a), t in [0, 1], keeps a non-empty part inside).
bool SegmentMeetsRect(const Pt& a, const Pt& b, double x0, double y0, double x1, double y1) {
  double t0 = 0.0, t1 = 1.0;
  const double d[2] = {b[0] - a[0], b[1] - a[1]};
  const double lo[2] = {x0, y0}, hi[2] = {x1, y1};
  for (int k = 0; k < 2; ++k) {
    for (const auto& [p, q] : {std::pair{-d[k], a[k] - lo[k]}, std::pair{d[k], hi[k] - a[k]}}) {
      if (p == 0.0) {
        if (q < 0.0) return false;
        continue;
      }
      const double r = q / p;
      if (p < 0.0) t0 = std::max(t0, r);
      else t1 = std::min(t1, r);
      if (t0 > t1) return false;
    }
  }
  return true;
}

// Whether any series (its points, or its line segments) or reference line enters the rectangle.
bool DataInRect(const Plot2D& plot, const Layout2D& L, double x0, double y0, double x1, double y1) {
  for (const Series& s : plot.series) {
    const std::vector<Pt> pts = SeriesPixels(s, L);
    for (size_t i = 0; i < pts.size(); ++i) {
      if (!std::isfinite(pts[i][0])) continue;
      if (pts[i][0] >= x0 && pts[i][0] <= x1 && pts[i][1] >= y0 && pts[i][1] <= y1) return true;
      if (s.style != SeriesStyle::kScatter && i + 1 < pts.size() && std::isfinite(pts[i + 1][0]) &&
          SegmentMeetsRect(pts[i], pts[i + 1], x0, y0, x1, y1)) {
        return true;
      }
    }
  }
  for (const RefLine& r : plot.ref_lines) {
    const bool horizontal = r.axis == RefLine::Axis::kHorizontal;
    const double v = horizontal ? L.YToPx(r.value) : L.XToPx(r.value);
    if (horizontal ? (v >= y0 && v <= y1) : (v >= x0 && v <= x1)) return true;
  }
  return false;
}

// The first corner, starting with the requested one, whose legend box no data enters.
std::optional<LegendPosition> EmptyCorner(const Plot2D& plot, const Layout2D& L, const Style& st, const Pt& size) {
  std::vector<LegendPosition> order = {plot.legend};
  for (LegendPosition p : {LegendPosition::kTopRight, LegendPosition::kTopLeft, LegendPosition::kBottomRight,
                           LegendPosition::kBottomLeft}) {
    if (p != plot.legend) order.push_back(p);
  }
  const double margin = 3.0 * st.scale;  // half a line width plus a gap
  for (LegendPosition p : order) {
    const Pt at = LegendCorner(st, size, p, L.left_px, L.top_px, L.right_px, L.bottom_px);
    if (!DataInRect(plot, L, at[0] - margin, at[1] - margin, at[0] + size[0] + margin, at[1] + size[1] + margin)) {
      return p;
    }
  }
  return std::nullopt;
}

double MaxWidth(Canvas& canvas, const std::vector<double>& ticks, double size_px) {
  double w = 0.0;
  const double step = ticks.size() > 1 ? ticks[1] - ticks[0] : 1.0;
  for (double t : ticks) w = std::max(w, canvas.Measure(FormatTick(t, step), size_px).width_px);
  return w;
}

// The largest tick count (≤ target) whose labels do not collide along x.
std::vector<double> XTicksThatFit(Canvas& canvas, const Range& r, double length_px, double size_px, int target) {
  for (int n = target; n >= 1; --n) {
    std::vector<double> ticks = NiceTicks(r.lo, r.hi, n);
    if (ticks.size() < 2) return ticks;
    const double spacing_px = (ticks[1] - ticks[0]) / (r.hi - r.lo) * length_px;
    if (MaxWidth(canvas, ticks, size_px) + 10.0 <= spacing_px) return ticks;
  }
  return NiceTicks(r.lo, r.hi, 1);
}

}  // namespace

Result<Layout2D> LayoutPlot2D(Canvas& canvas, const Plot2D& plot, double x0, double y0, double w, double h) {
  HEXSIM_RETURN_IF_ERROR(CheckRange(plot.x_range, "x_range"));
  HEXSIM_RETURN_IF_ERROR(CheckRange(plot.y_range, "y_range"));
  for (const Series& s : plot.series) {
    if (s.x.size() != s.y.size()) {
      return Status::BadInput("render: series '" + s.label + "': x and y differ in length");
    }
  }
  const Style st = Style::ForPanel(w, h);
  const double inf = std::numeric_limits<double>::infinity();
  double xlo = inf, xhi = -inf, ylo = inf, yhi = -inf;
  for (const Series& s : plot.series) {
    for (size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      Extend(s.x[i], &xlo, &xhi);
      Extend(s.y[i], &ylo, &yhi);
    }
  }
  for (const RefLine& r : plot.ref_lines) {
    if (r.axis == RefLine::Axis::kHorizontal) Extend(r.value, &ylo, &yhi);
    else Extend(r.value, &xlo, &xhi);
  }
  Layout2D L;
  L.x = plot.x_range ? *plot.x_range : Finish(xlo, xhi);
  L.y = plot.y_range ? *plot.y_range : Finish(ylo, yhi);

  const double tick_h = canvas.Measure("0", st.tick_px()).height_px;
  const double label_h = canvas.Measure("Ag", st.label_px()).height_px;
  const double title_h = plot.title.empty() ? 0.0 : canvas.Measure(plot.title, st.title_px()).height_px + st.pad_px();
  const double tick_len = 4.0 * st.scale;
  L.top_px = y0 + st.pad_px() + title_h + tick_h * 0.5;
  L.bottom_px = y0 + h - st.pad_px() - (plot.x_label.empty() ? 0.0 : label_h + 2.0) - tick_h - tick_len - 4.0;
  L.right_px = x0 + w - st.pad_px() - 12.0 * st.scale;
  // The frame sits on pixel centres, so 1-px lines stay crisp.
  L.top_px = Snap(L.top_px);
  L.bottom_px = Snap(L.bottom_px);
  L.right_px = Snap(L.right_px);
  // Two passes: the y tick labels' width sets the left margin.
  double left_extra = 0.0;
  for (int pass = 0; pass < 2; ++pass) {
    L.left_px = x0 + st.pad_px() + (plot.y_label.empty() ? 0.0 : label_h + 6.0) + left_extra + tick_len + 5.0;
    L.left_px = Snap(L.left_px);
    const double pw = L.right_px - L.left_px, ph = L.bottom_px - L.top_px;
    if (pw < 10.0 || ph < 10.0) return Status::BadInput("render: image too small for the plot '" + plot.title + "'");
    if (plot.equal_aspect) {
      // Widen one range so one data unit spans the same pixels on both axes.
      Range x = plot.x_range ? *plot.x_range : Finish(xlo, xhi);
      Range y = plot.y_range ? *plot.y_range : Finish(ylo, yhi);
      const double upp = std::max((x.hi - x.lo) / pw, (y.hi - y.lo) / ph);
      const double xc = 0.5 * (x.lo + x.hi), yc = 0.5 * (y.lo + y.hi);
      L.x = {xc - 0.5 * upp * pw, xc + 0.5 * upp * pw};
      L.y = {yc - 0.5 * upp * ph, yc + 0.5 * upp * ph};
    }
    L.y_ticks = NiceTicks(L.y.lo, L.y.hi, std::clamp(static_cast<int>(ph / (48.0 * st.scale)), 2, 9));
    left_extra = MaxWidth(canvas, L.y_ticks, st.tick_px());
    if (pass == 1) {
      L.x_ticks = XTicksThatFit(canvas, L.x, pw, st.tick_px(), std::clamp(static_cast<int>(pw / (70.0 * st.scale)), 2, 10));
    }
  }
  return L;
}

Pt LegendSize(Canvas& canvas, const Style& st, const std::vector<LegendEntry>& entries) {
  const double font = st.legend_px();
  const double row_h = canvas.Measure("Ag", font).height_px * 1.15;
  const double sample_w = 22.0 * st.scale, gap = 6.0 * st.scale, pad = 6.0 * st.scale;
  double text_w = 0.0;
  for (const LegendEntry& e : entries) text_w = std::max(text_w, canvas.Measure(e.label, font).width_px);
  return {pad + sample_w + gap + text_w + pad, pad + row_h * static_cast<double>(entries.size()) + pad};
}

Pt LegendCorner(const Style& st, const Pt& size, LegendPosition where, double x0, double y0, double x1, double y1) {
  const double inset = 8.0 * st.scale;
  const bool right = where == LegendPosition::kTopRight || where == LegendPosition::kBottomRight;
  const bool top = where == LegendPosition::kTopRight || where == LegendPosition::kTopLeft;
  return {right ? x1 - inset - size[0] : x0 + inset, top ? y0 + inset : y1 - inset - size[1]};
}

void DrawLegend(Canvas& canvas, const Style& st, const std::vector<LegendEntry>& entries, LegendPosition where,
                double x0, double y0, double x1, double y1) {
  if (where == LegendPosition::kNone || entries.empty()) return;
  const Pt size = LegendSize(canvas, st, entries);
  const Pt at = LegendCorner(st, size, where, x0, y0, x1, y1);
  DrawLegendAt(canvas, st, entries, at[0], at[1]);
}

void DrawLegendAt(Canvas& canvas, const Style& st, const std::vector<LegendEntry>& entries, double bx, double by) {
  const double font = st.legend_px();
  const double row_h = canvas.Measure("Ag", font).height_px * 1.15;
  const double sample_w = 22.0 * st.scale, gap = 6.0 * st.scale, pad = 6.0 * st.scale;
  const Pt size = LegendSize(canvas, st, entries);
  const double bw = size[0], bh = size[1];
  canvas.FillRect(bx, by, bx + bw, by + bh, {1.0f, 1.0f, 1.0f, 0.88f});
  canvas.StrokeRect(bx, by, bx + bw, by + bh, {0.75f, 0.75f, 0.75f, 1.0f}, 1.0);
  for (size_t i = 0; i < entries.size(); ++i) {
    const LegendEntry& e = entries[i];
    const double cy = by + pad + row_h * (i + 0.5);
    const double sx0 = bx + pad, sx1 = sx0 + sample_w;
    if (e.style != SeriesStyle::kScatter) canvas.Line(sx0, cy, sx1, cy, e.colour, kMaxLineWidth_px, e.dashed);
    if (e.style != SeriesStyle::kLine) canvas.Discs({{0.5 * (sx0 + sx1), cy}}, e.colour, 6.0 * st.scale);
    canvas.Text(e.label, sx1 + gap, cy, font, kInk, HAlign::kLeft, VAlign::kMiddle);
  }
}

namespace {

std::vector<LegendEntry> LegendEntries(const Plot2D& plot) {
  std::vector<LegendEntry> legend;
  size_t auto_colour = 0;
  for (const Series& s : plot.series) {
    const Colour c = s.colour ? *s.colour : PaletteColour(auto_colour++);
    if (!s.label.empty()) legend.push_back({s.label, c, s.style, s.dashed});
  }
  return legend;
}

}  // namespace

Result<Placed2D> PlacePlot2D(Canvas& canvas, const Plot2D& plot, double x0, double y0, double w, double h) {
  const Style st = Style::ForPanel(w, h);
  Result<Layout2D> layout = LayoutPlot2D(canvas, plot, x0, y0, w, h);
  if (!layout.ok()) return layout.status();
  Placed2D placed{*layout, std::nullopt};
  const std::vector<LegendEntry> legend = LegendEntries(plot);
  if (plot.legend == LegendPosition::kNone || legend.empty()) return placed;
  // The legend goes in a corner no data crosses (the requested one first); where every corner has
  // data, outside the plot area on the right, which narrows the plot.
  const Pt size = LegendSize(canvas, st, legend);
  if (const auto corner = EmptyCorner(plot, *layout, st, size)) {
    const Pt at = LegendCorner(st, size, *corner, layout->left_px, layout->top_px, layout->right_px, layout->bottom_px);
    placed.legend = LegendBox{at[0], at[1], size[0], size[1], false};
    return placed;
  }
  const double gap = 8.0 * st.scale;
  auto narrowed = LayoutPlot2D(canvas, plot, x0, y0, w - size[0] - gap, h);
  if (!narrowed.ok()) return placed;  // too small to move it out: the requested corner
  placed.layout = *narrowed;
  placed.legend = LegendBox{narrowed->right_px + gap, narrowed->top_px, size[0], size[1], true};
  return placed;
}

Status DrawPlot2D(Canvas& canvas, const Plot2D& plot, double x0, double y0, double w, double h) {
  const Style st = Style::ForPanel(w, h);
  Result<Placed2D> placed = PlacePlot2D(canvas, plot, x0, y0, w, h);
  if (!placed.ok()) return placed.status();
  const Layout2D& L = placed->layout;
  const double tick_len = 4.0 * st.scale;

  canvas.Clip(L.left_px, L.top_px, L.right_px, L.bottom_px);
  for (const XSpan& s : plot.spans) {
    const double a = L.XToPx(std::min(s.lo, s.hi)), b = L.XToPx(std::max(s.lo, s.hi));
    canvas.FillRect(a, L.top_px, b, L.bottom_px, s.colour);
  }
  if (plot.grid) {
    for (double t : L.x_ticks) canvas.Line(Snap(L.XToPx(t)), L.top_px, Snap(L.XToPx(t)), L.bottom_px, kGrid, 1.0);
    for (double t : L.y_ticks) canvas.Line(L.left_px, Snap(L.YToPx(t)), L.right_px, Snap(L.YToPx(t)), kGrid, 1.0);
  }
  for (const RefLine& r : plot.ref_lines) {
    if (r.axis == RefLine::Axis::kHorizontal) {
      canvas.Line(L.left_px, L.YToPx(r.value), L.right_px, L.YToPx(r.value), r.colour, 1.2 * st.scale, true);
    } else {
      canvas.Line(L.XToPx(r.value), L.top_px, L.XToPx(r.value), L.bottom_px, r.colour, 1.2 * st.scale, true);
    }
  }
  size_t auto_colour = 0;
  for (const Series& s : plot.series) {
    const Colour c = s.colour ? *s.colour : PaletteColour(auto_colour++);
    const std::vector<Pt> pts = SeriesPixels(s, L);
    if (s.style != SeriesStyle::kScatter) canvas.Polyline(pts, c, LineWidth(s.width_px, st), s.dashed);
    if (s.style != SeriesStyle::kLine) canvas.Discs(pts, c, s.marker_px * st.scale);
  }
  canvas.Unclip();
  // Span and reference-line labels, inside the plot area.
  for (const XSpan& s : plot.spans) {
    if (s.label.empty()) continue;
    const double a = L.XToPx(std::min(s.lo, s.hi)), b = L.XToPx(std::max(s.lo, s.hi));
    const double cx = 0.5 * (std::max(a, L.left_px) + std::min(b, L.right_px));
    if (canvas.Measure(s.label, st.tick_px() * 0.9).width_px < (b - a) - 4.0) {
      canvas.Text(s.label, cx, L.top_px + 3.0, st.tick_px() * 0.9, kMuted, HAlign::kCenter, VAlign::kTop);
    }
  }
  for (const RefLine& r : plot.ref_lines) {
    if (r.label.empty()) continue;
    if (r.axis == RefLine::Axis::kHorizontal) {
      canvas.Text(r.label, L.left_px + 4.0, L.YToPx(r.value) - 2.0, st.tick_px() * 0.9, r.colour, HAlign::kLeft,
                  VAlign::kBottom);
    } else {
      canvas.Text(r.label, L.XToPx(r.value) + 3.0, L.bottom_px - 3.0, st.tick_px() * 0.9, r.colour, HAlign::kLeft,
                  VAlign::kBottom, true);
    }
  }
  // Frame, ticks, tick labels.
  canvas.StrokeRect(L.left_px, L.top_px, L.right_px, L.bottom_px, kInk, 1.0);
  const double xstep = L.x_ticks.size() > 1 ? L.x_ticks[1] - L.x_ticks[0] : 1.0;
  for (double t : L.x_ticks) {
    const double px = Snap(L.XToPx(t));
    canvas.Line(px, L.bottom_px, px, L.bottom_px + tick_len, kInk, 1.0);
    canvas.Text(FormatTick(t, xstep), px, L.bottom_px + tick_len + 2.0, st.tick_px(), kInk, HAlign::kCenter,
                VAlign::kTop);
  }
  const double ystep = L.y_ticks.size() > 1 ? L.y_ticks[1] - L.y_ticks[0] : 1.0;
  for (double t : L.y_ticks) {
    const double py = Snap(L.YToPx(t));
    canvas.Line(L.left_px - tick_len, py, L.left_px, py, kInk, 1.0);
    canvas.Text(FormatTick(t, ystep), L.left_px - tick_len - 3.0, py, st.tick_px(), kInk, HAlign::kRight,
                VAlign::kMiddle);
  }
  // Axis titles and plot title.
  const double pw_mid = 0.5 * (L.left_px + L.right_px);
  if (!plot.x_label.empty()) {
    canvas.Text(plot.x_label, pw_mid, y0 + h - st.pad_px(), st.label_px(), kInk, HAlign::kCenter, VAlign::kBottom);
  }
  if (!plot.y_label.empty()) {
    canvas.Text(plot.y_label, x0 + st.pad_px(), 0.5 * (L.top_px + L.bottom_px), st.label_px(), kInk, HAlign::kLeft,
                VAlign::kMiddle, true);
  }
  if (!plot.title.empty()) {
    canvas.Text(plot.title, pw_mid, y0 + st.pad_px(), st.title_px(), kInk, HAlign::kCenter, VAlign::kTop);
  }
  if (placed->legend) DrawLegendAt(canvas, st, LegendEntries(plot), placed->legend->x_px, placed->legend->y_px);
  return Status::Ok();
}

}  // namespace internal

Result<Layout2D> ComputeLayout(const Plot2D& plot, int width, int height) {
  Result<std::unique_ptr<internal::Canvas>> canvas = internal::Canvas::Create(internal::kMinSize_px, internal::kMinSize_px);
  if (!canvas.ok()) return canvas.status();
  if (width < internal::kMinSize_px || height < internal::kMinSize_px) return Status::BadInput("render: image too small");
  return internal::LayoutPlot2D(**canvas, plot, 0.0, 0.0, width, height);
}

Result<std::optional<LegendBox>> ComputeLegendBox(const Plot2D& plot, int width, int height) {
  Result<std::unique_ptr<internal::Canvas>> canvas = internal::Canvas::Create(internal::kMinSize_px, internal::kMinSize_px);
  if (!canvas.ok()) return canvas.status();
  if (width < internal::kMinSize_px || height < internal::kMinSize_px) return Status::BadInput("render: image too small");
  auto placed = internal::PlacePlot2D(**canvas, plot, 0.0, 0.0, width, height);
  if (!placed.ok()) return placed.status();
  return placed->legend;
}

Result<Image> Render(const Plot2D& plot, int width, int height) {
  Result<std::unique_ptr<internal::Canvas>> canvas = internal::Canvas::Create(width, height);
  if (!canvas.ok()) return canvas.status();
  HEXSIM_RETURN_IF_ERROR(internal::DrawPlot2D(**canvas, plot, 0.0, 0.0, width, height));
  return (*canvas)->Finish();
}

}  // namespace hexsim::render
