#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "draw.h"

namespace hexsim::render {
namespace internal {
namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
constexpr int kEllipseSegments = 64;

using V3 = std::array<double, 3>;

double Dot(const V3& a, const V3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// Orthographic camera: data → normalised box [-a_i, a_i] → screen.
struct Camera {
  V3 right{}, up{}, toward{};  // screen right, screen up, direction towards the viewer
  V3 mid{}, half{}, box{};     // data centre, data half-range, box half-size per axis
  double cx = 0, cy = 0, k = 1;

  V3 Normalise(const V3& p) const {
    return {(p[0] - mid[0]) / half[0] * box[0], (p[1] - mid[1]) / half[1] * box[1], (p[2] - mid[2]) / half[2] * box[2]};
  }
  Pt ScreenOfBox(const V3& n) const { return {cx + k * Dot(n, right), cy - k * Dot(n, up)}; }
  Pt Screen(const V3& p) const {
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) return {NAN, NAN};
    return ScreenOfBox(Normalise(p));
  }
};

void Extend(double v, double* lo, double* hi) {
  if (!std::isfinite(v)) return;
  *lo = std::min(*lo, v);
  *hi = std::max(*hi, v);
}

Range FinishRange(double lo, double hi) {
  if (!(lo <= hi)) return {-1.0, 1.0};
  if (hi - lo < 1e-12 * std::max(1.0, std::fabs(lo))) {
    const double h = std::max(std::fabs(lo) * 0.05, 0.5);
    return {lo - h, hi + h};
  }
  const double m = 0.03 * (hi - lo);
  return {lo - m, hi + m};
}

HAlign HFor(double dx) { return dx > 0.35 ? HAlign::kLeft : (dx < -0.35 ? HAlign::kRight : HAlign::kCenter); }
VAlign VFor(double dy) { return dy > 0.35 ? VAlign::kTop : (dy < -0.35 ? VAlign::kBottom : VAlign::kMiddle); }

Status ValidatePlot3D(const Plot3D& plot) {
  for (const Series3D& s : plot.series) {
    if (s.x.size() != s.y.size() || s.x.size() != s.z.size()) {
      return Status::BadInput("render: 3-D series '" + s.label + "': x, y, z differ in length");
    }
  }
  for (const auto* r : {&plot.x_range, &plot.y_range, &plot.z_range}) {
    if (*r && !(std::isfinite((*r)->lo) && std::isfinite((*r)->hi) && (*r)->hi > (*r)->lo)) {
      return Status::BadInput("render: 3-D plot '" + plot.title + "': range must be finite with hi > lo");
    }
  }
  return Status::Ok();
}

// Each axis' range: the plot's own, or what the finite points and the ellipsoids span.
std::array<Range, 3> AxisRanges(const Plot3D& plot) {
  const double inf = std::numeric_limits<double>::infinity();
  double lo[3] = {inf, inf, inf}, hi[3] = {-inf, -inf, -inf};
  for (const Series3D& s : plot.series) {
    for (size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i]) || !std::isfinite(s.z[i])) continue;
      Extend(s.x[i], &lo[0], &hi[0]);
      Extend(s.y[i], &lo[1], &hi[1]);
      Extend(s.z[i], &lo[2], &hi[2]);
    }
  }
  for (const Ellipsoid3D& e : plot.ellipsoids) {
    for (int a = 0; a < 3; ++a) {
      const double r = std::sqrt(Dot(e.shape[static_cast<size_t>(a)], e.shape[static_cast<size_t>(a)]));
      Extend(e.centre[static_cast<size_t>(a)] - r, &lo[a], &hi[a]);
      Extend(e.centre[static_cast<size_t>(a)] + r, &lo[a], &hi[a]);
    }
  }
  return {plot.x_range ? *plot.x_range : FinishRange(lo[0], hi[0]), plot.y_range ? *plot.y_range : FinishRange(lo[1], hi[1]),
          plot.z_range ? *plot.z_range : FinishRange(lo[2], hi[2])};
}

// The camera's box and view direction (its screen scale and centre: FitCamera).
Camera Orient(const Plot3D& plot, const std::array<Range, 3>& ranges) {
  Camera cam;
  double max_half = 0.0;
  for (int a = 0; a < 3; ++a) {
    cam.mid[static_cast<size_t>(a)] = 0.5 * (ranges[static_cast<size_t>(a)].lo + ranges[static_cast<size_t>(a)].hi);
    cam.half[static_cast<size_t>(a)] = 0.5 * (ranges[static_cast<size_t>(a)].hi - ranges[static_cast<size_t>(a)].lo);
    max_half = std::max(max_half, cam.half[static_cast<size_t>(a)]);
  }
  for (size_t a = 0; a < 3; ++a) cam.box[a] = plot.equal_aspect ? cam.half[a] / max_half : 1.0;
  const double az = plot.azimuth_deg * kDegToRad, el = plot.elevation_deg * kDegToRad;
  cam.toward = {std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)};
  cam.right = {-std::sin(az), std::cos(az), 0.0};
  cam.up = {-std::sin(el) * std::cos(az), -std::sin(el) * std::sin(az), std::cos(el)};
  return cam;
}

// Fits the projected box into the panel below a title of height title_h, leaving room for the tick labels.
Status FitCamera(const Style& st, double title_h, double x0, double y0, double w, double h, Camera* cam) {
  const double inf = std::numeric_limits<double>::infinity();
  const double margin = 62.0 * st.scale;
  const double ax0 = x0 + margin, ax1 = x0 + w - margin;
  const double ay0 = y0 + st.pad_px() + title_h + 0.6 * margin, ay1 = y0 + h - margin;
  double smin[2] = {inf, inf}, smax[2] = {-inf, -inf};
  for (int c = 0; c < 8; ++c) {
    const V3 n = {(c & 1 ? 1 : -1) * cam->box[0], (c & 2 ? 1 : -1) * cam->box[1], (c & 4 ? 1 : -1) * cam->box[2]};
    const double sx = Dot(n, cam->right), sy = Dot(n, cam->up);
    smin[0] = std::min(smin[0], sx);
    smax[0] = std::max(smax[0], sx);
    smin[1] = std::min(smin[1], sy);
    smax[1] = std::max(smax[1], sy);
  }
  if (ax1 - ax0 < 10.0 || ay1 - ay0 < 10.0) return Status::BadInput("render: image too small for the 3-D plot");
  cam->k = std::min((ax1 - ax0) / (smax[0] - smin[0]), (ay1 - ay0) / (smax[1] - smin[1]));
  cam->cx = 0.5 * (ax0 + ax1) - cam->k * 0.5 * (smin[0] + smax[0]);
  cam->cy = 0.5 * (ay0 + ay1) + cam->k * 0.5 * (smin[1] + smax[1]);
  return Status::Ok();
}

using Ticks = std::array<std::vector<double>, 3>;

// Back panes (the side of each axis away from the viewer), with grid lines at the ticks.
void DrawBackPanes(Canvas& canvas, const Camera& cam, const Ticks& ticks) {
  const Colour pane = {0.95f, 0.95f, 0.96f, 1.0f};
  const Colour pane_edge = {0.62f, 0.62f, 0.62f, 1.0f};
  for (int a = 0; a < 3; ++a) {
    const size_t ia = static_cast<size_t>(a);
    const size_t ib = (ia + 1) % 3, ic = (ia + 2) % 3;
    const double fixed = (cam.toward[ia] > 0 ? -1.0 : 1.0) * cam.box[ia];
    auto P = [&](double b, double c) {
      V3 n{};
      n[ia] = fixed;
      n[ib] = b;
      n[ic] = c;
      return cam.ScreenOfBox(n);
    };
    const double bb = cam.box[ib], bc = cam.box[ic];
    const std::vector<Pt> quad = {P(-bb, -bc), P(bb, -bc), P(bb, bc), P(-bb, bc), P(-bb, -bc)};
    canvas.FillQuad(quad[0], quad[1], quad[2], quad[3], pane);
    for (double v : ticks[ib]) {
      const double nb = (v - cam.mid[ib]) / cam.half[ib] * cam.box[ib];
      const Pt p0 = P(nb, -bc), p1 = P(nb, bc);
      canvas.Line(p0[0], p0[1], p1[0], p1[1], kGrid, 1.0);
    }
    for (double v : ticks[ic]) {
      const double nc = (v - cam.mid[ic]) / cam.half[ic] * cam.box[ic];
      const Pt p0 = P(-bb, nc), p1 = P(bb, nc);
      canvas.Line(p0[0], p0[1], p1[0], p1[1], kGrid, 1.0);
    }
    canvas.Polyline(quad, pane_edge, 1.0);
  }
}

// An edge of the box that carries an axis' ticks and label.
struct AxisEdge {
  V3 a, b;  // ends in box coordinates
  int axis;
  const std::string* label;
};

// The edges that carry the tick labels: front-bottom edges for x and y, a side edge for z (the
// vertical edge at the corner furthest to the left on screen).
std::array<AxisEdge, 3> LabelledEdges(const Plot3D& plot, const Camera& cam) {
  const double sx_front = cam.toward[0] > 0 ? 1.0 : -1.0, sy_front = cam.toward[1] > 0 ? 1.0 : -1.0;
  const double zb = -cam.box[2];
  double best = std::numeric_limits<double>::infinity();
  V3 zcorner{};
  for (int c = 0; c < 4; ++c) {
    const V3 n = {(c & 1 ? 1 : -1) * cam.box[0], (c & 2 ? 1 : -1) * cam.box[1], 0.0};
    const double sx = Dot(n, cam.right) - 1e-6 * Dot(n, cam.toward);
    if (sx < best) {
      best = sx;
      zcorner = n;
    }
  }
  return {AxisEdge{{-cam.box[0], sy_front * cam.box[1], zb}, {cam.box[0], sy_front * cam.box[1], zb}, 0, &plot.x_label},
          AxisEdge{{sx_front * cam.box[0], -cam.box[1], zb}, {sx_front * cam.box[0], cam.box[1], zb}, 1, &plot.y_label},
          AxisEdge{{zcorner[0], zcorner[1], -cam.box[2]}, {zcorner[0], zcorner[1], cam.box[2]}, 2, &plot.z_label}};
}

// One axis' edge, its ticks and tick labels pointing away from the box's centre, and its label.
void DrawAxisEdge(Canvas& canvas, const Style& st, const Camera& cam, const AxisEdge& e, const std::vector<double>& ticks) {
  const Pt centre = cam.ScreenOfBox({0.0, 0.0, 0.0});
  const size_t ax = static_cast<size_t>(e.axis);
  const Pt mid_edge = cam.ScreenOfBox({0.5 * (e.a[0] + e.b[0]), 0.5 * (e.a[1] + e.b[1]), 0.5 * (e.a[2] + e.b[2])});
  double dx = mid_edge[0] - centre[0], dy = mid_edge[1] - centre[1];
  if (e.axis == 2) dy = 0.0;  // z labels sit beside their edge
  const double len = std::hypot(dx, dy);
  if (len < 1e-9) {
    dx = 0.0;
    dy = 1.0;
  } else {
    dx /= len;
    dy /= len;
  }
  const Pt pa = cam.ScreenOfBox(e.a), pb = cam.ScreenOfBox(e.b);
  canvas.Line(pa[0], pa[1], pb[0], pb[1], kInk, 1.0);
  const double step = ticks.size() > 1 ? ticks[1] - ticks[0] : 1.0;
  double widest = 0.0;
  for (double v : ticks) {
    V3 n = e.a;
    n[ax] = (v - cam.mid[ax]) / cam.half[ax] * cam.box[ax];
    const Pt p = cam.ScreenOfBox(n);
    canvas.Line(p[0], p[1], p[0] + dx * 4.0 * st.scale, p[1] + dy * 4.0 * st.scale, kInk, 1.0);
    const std::string text = FormatTick(v, step);
    widest = std::max(widest, canvas.Measure(text, st.tick_px()).width_px);
    canvas.Text(text, p[0] + dx * 7.0 * st.scale, p[1] + dy * 7.0 * st.scale, st.tick_px(), kInk, HFor(dx), VFor(dy));
  }
  if (!e.label->empty()) {
    const double off = 7.0 * st.scale + (std::fabs(dx) > 0.35 ? widest : 0.0) +
                       (std::fabs(dy) > 0.35 ? canvas.Measure("0", st.tick_px()).height_px : 0.0) + 8.0 * st.scale;
    canvas.Text(*e.label, mid_edge[0] + dx * off, mid_edge[1] + dy * off, st.label_px(), kInk, HFor(dx), VFor(dy),
                e.axis == 2);
  }
}

// An ellipsoid as a wire frame: rings of constant polar angle and meridians.
void DrawEllipsoid(Canvas& canvas, const Camera& cam, const Ellipsoid3D& e, Colour wire) {
  auto On = [&](double theta, double phi) {  // u on the unit sphere, p = centre + shape·u
    const V3 u = {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
    return cam.Screen({e.centre[0] + Dot(e.shape[0], u), e.centre[1] + Dot(e.shape[1], u),
                       e.centre[2] + Dot(e.shape[2], u)});
  };
  constexpr int kRings = 7, kMeridians = 12, kHalfSegments = kEllipseSegments / 2;
  for (int i = 1; i <= kRings; ++i) {
    std::vector<Pt> ring;
    const double theta = 3.14159265358979323846 * i / (kRings + 1);
    for (int j = 0; j <= kEllipseSegments; ++j) ring.push_back(On(theta, 2.0 * 3.14159265358979323846 * j / kEllipseSegments));
    canvas.Polyline(ring, wire, 1.0);
  }
  for (int j = 0; j < kMeridians; ++j) {
    std::vector<Pt> meridian;
    const double phi = 2.0 * 3.14159265358979323846 * j / kMeridians;
    for (int i = 0; i <= kHalfSegments; ++i) meridian.push_back(On(3.14159265358979323846 * i / kHalfSegments, phi));
    canvas.Polyline(meridian, wire, 1.0);
  }
}

}  // namespace

Status DrawPlot3D(Canvas& canvas, const Plot3D& plot, double x0, double y0, double w, double h) {
  HEXSIM_RETURN_IF_ERROR(ValidatePlot3D(plot));
  const Style st = Style::ForPanel(w, h);
  const std::array<Range, 3> ranges = AxisRanges(plot);
  Camera cam = Orient(plot, ranges);
  const double title_h = plot.title.empty() ? 0.0 : canvas.Measure(plot.title, st.title_px()).height_px + st.pad_px();
  HEXSIM_RETURN_IF_ERROR(FitCamera(st, title_h, x0, y0, w, h, &cam));
  Ticks ticks;
  for (size_t a = 0; a < 3; ++a) ticks[a] = NiceTicks(ranges[a].lo, ranges[a].hi, 5);
  DrawBackPanes(canvas, cam, ticks);
  for (const AxisEdge& e : LabelledEdges(plot, cam)) DrawAxisEdge(canvas, st, cam, e, ticks[static_cast<size_t>(e.axis)]);

  // Data.
  canvas.Clip(x0, y0, x0 + w, y0 + h);
  std::vector<LegendEntry> legend;
  size_t auto_colour = 0;
  for (const Ellipsoid3D& e : plot.ellipsoids) {
    const Colour c = e.colour ? *e.colour : PaletteColour(auto_colour++);
    Colour wire = c;
    wire.a *= 0.55f;
    DrawEllipsoid(canvas, cam, e, wire);
    if (!e.label.empty()) legend.push_back({e.label, c, SeriesStyle::kLine, false});
  }
  for (const Series3D& s : plot.series) {
    const Colour c = s.colour ? *s.colour : PaletteColour(auto_colour++);
    std::vector<Pt> pts(s.x.size());
    for (size_t i = 0; i < s.x.size(); ++i) pts[i] = cam.Screen({s.x[i], s.y[i], s.z[i]});
    if (s.style != SeriesStyle::kScatter) canvas.Polyline(pts, c, LineWidth(s.width_px, st));
    if (s.style != SeriesStyle::kLine) canvas.Discs(pts, c, s.marker_px * st.scale);
    if (!s.label.empty()) legend.push_back({s.label, c, s.style, false});
  }
  canvas.Unclip();
  if (!plot.title.empty()) {
    canvas.Text(plot.title, x0 + 0.5 * w, y0 + st.pad_px(), st.title_px(), kInk, HAlign::kCenter, VAlign::kTop);
  }
  DrawLegend(canvas, st, legend, plot.legend, x0, y0 + title_h, x0 + w, y0 + h);
  return Status::Ok();
}

}  // namespace internal

Result<Image> Render(const Plot3D& plot, int width, int height) {
  Result<std::unique_ptr<internal::Canvas>> canvas = internal::Canvas::Create(width, height);
  if (!canvas.ok()) return canvas.status();
  HEXSIM_RETURN_IF_ERROR(internal::DrawPlot3D(**canvas, plot, 0.0, 0.0, width, height));
  return (*canvas)->Finish();
}

Result<Image> Render(const Figure& figure, int width, int height) {
  if (figure.rows < 1 || figure.cols < 1) return Status::BadInput("render: figure needs at least one row and column");
  if (figure.panels.size() > static_cast<size_t>(figure.rows) * static_cast<size_t>(figure.cols)) {
    return Status::BadInput("render: figure has more panels than rows × cols");
  }
  Result<std::unique_ptr<internal::Canvas>> made = internal::Canvas::Create(width, height);
  if (!made.ok()) return made.status();
  internal::Canvas& canvas = **made;
  const internal::Style st = internal::Style::ForPanel(width, height);
  double top = 0.0;
  if (!figure.title.empty()) {
    const double size = st.title_px() * 1.1;
    canvas.Text(figure.title, 0.5 * width, st.pad_px(), size, internal::kInk, internal::HAlign::kCenter,
                internal::VAlign::kTop);
    top = st.pad_px() + canvas.Measure(figure.title, size).height_px;
  }
  const double cw = static_cast<double>(width) / figure.cols, ch = (height - top) / figure.rows;
  for (size_t i = 0; i < figure.panels.size(); ++i) {
    const size_t col = i % static_cast<size_t>(figure.cols), row = i / static_cast<size_t>(figure.cols);
    const double px = cw * static_cast<double>(col);
    const double py = top + ch * static_cast<double>(row);
    const auto& panel = figure.panels[i];
    if (const auto* p2 = std::get_if<Plot2D>(&panel)) {
      HEXSIM_RETURN_IF_ERROR(internal::DrawPlot2D(canvas, *p2, px, py, cw, ch));
    } else {
      HEXSIM_RETURN_IF_ERROR(internal::DrawPlot3D(canvas, std::get<Plot3D>(panel), px, py, cw, ch));
    }
  }
  return canvas.Finish();
}

}  // namespace hexsim::render
