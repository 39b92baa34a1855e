#include "hexsim/render/figures.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <string>

#include "hexsim/common/atomic_file.h"
#include "hexsim/common/rotation.h"

namespace hexsim::render {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr size_t kMaxPhases = 30;

bool HasData(const logs::FlightLog& log, const std::string& name) {
  if (!log.Has(name)) return false;
  for (double v : log.Column(name)) {
    if (std::isfinite(v)) return true;
  }
  return false;
}

bool HasAll(const logs::FlightLog& log, std::initializer_list<const char*> names) {
  for (const char* n : names) {
    if (!HasData(log, n)) return false;
  }
  return true;
}

std::vector<double> Negated(const std::vector<double>& v) {
  std::vector<double> out(v.size());
  for (size_t i = 0; i < v.size(); ++i) out[i] = -v[i];
  return out;
}

Series Line(std::string label, std::vector<double> x, std::vector<double> y, std::optional<Colour> c = {}) {
  Series s;
  s.label = std::move(label);
  s.x = std::move(x);
  s.y = std::move(y);
  s.colour = c;
  return s;
}

// Breaks an angle series (deg) where it wraps through ±180, so no vertical line joins the ends.
void BreakWraps(std::vector<double>* x, std::vector<double>* y) {
  std::vector<double> ox, oy;
  for (size_t i = 0; i < y->size(); ++i) {
    if (i > 0 && std::isfinite((*y)[i]) && std::isfinite((*y)[i - 1]) && std::fabs((*y)[i] - (*y)[i - 1]) > 180.0) {
      ox.push_back(kNaN);
      oy.push_back(kNaN);
    }
    ox.push_back((*x)[i]);
    oy.push_back((*y)[i]);
  }
  *x = std::move(ox);
  *y = std::move(oy);
}

// ArduCopter's mode numbers (ArduCopter/mode.h, Mode::Number) and PX4's navigation states
// (vehicle_status.nav_state), as their ground stations name them.
const std::map<int, const char*> kArduCopterModes = {
    {0, "Stabilize"}, {1, "Acro"},     {2, "AltHold"},  {3, "Auto"},      {4, "Guided"},    {5, "Loiter"},
    {6, "RTL"},       {7, "Circle"},   {9, "Land"},     {11, "Drift"},    {13, "Sport"},    {14, "Flip"},
    {15, "AutoTune"}, {16, "PosHold"}, {17, "Brake"},   {18, "Throw"},    {19, "Avoid_ADSB"}, {20, "Guided_NoGPS"},
    {21, "Smart_RTL"}, {22, "FlowHold"}, {23, "Follow"}, {24, "ZigZag"}, {25, "SystemID"}, {27, "Auto_RTL"}};
const std::map<int, const char*> kPx4NavStates = {
    {0, "Manual"},   {1, "Altitude"}, {2, "Position"}, {3, "Mission"},    {4, "Hold"},      {5, "Return"},
    {10, "Acro"},    {12, "Descend"}, {13, "Termination"}, {14, "Offboard"}, {15, "Stabilized"}, {17, "Takeoff"},
    {18, "Land"},    {19, "Follow target"}, {20, "Precision land"}, {21, "Orbit"}};

// Flight phases: runs of constant `mode`, shaded alternately.
std::vector<XSpan> Phases(const logs::FlightLog& log) {
  std::vector<XSpan> spans;
  if (!HasAll(log, {"t_s", "mode"})) return spans;
  const auto& t = log.Column("t_s");
  const auto& mode = log.Column("mode");
  size_t start = 0;
  for (size_t i = 1; i <= t.size(); ++i) {
    const bool boundary = i == t.size() || !(mode[i] == mode[start] || (std::isnan(mode[i]) && std::isnan(mode[start])));
    if (!boundary) continue;
    if (std::isfinite(mode[start])) {
      XSpan s;
      s.lo = t[start];
      s.hi = i < t.size() ? t[i] : t[i - 1];
      s.label = FlightModeLabel(log.meta, mode[start]);
      s.colour = spans.size() % 2 == 0 ? Colour{0.12f, 0.47f, 0.71f, 0.07f} : Colour{0.5f, 0.5f, 0.5f, 0.10f};
      spans.push_back(s);
    }
    start = i;
  }
  if (spans.size() < 2 || spans.size() > kMaxPhases) spans.clear();
  return spans;
}

Plot2D TimePlot(const logs::FlightLog& log, std::string title, std::string y_label) {
  Plot2D p;
  p.title = std::move(title);
  p.x_label = "time (s)";
  p.y_label = std::move(y_label);
  p.spans = Phases(log);
  return p;
}

struct Euler {
  std::vector<double> roll_deg, pitch_deg, yaw_deg;
};

Euler EulerColumns(const logs::FlightLog& log, const std::string& prefix) {
  const auto& w = log.Column(prefix + "w");
  const auto& x = log.Column(prefix + "x");
  const auto& y = log.Column(prefix + "y");
  const auto& z = log.Column(prefix + "z");
  Euler e;
  for (size_t i = 0; i < w.size(); ++i) {
    Eigen::Quaterniond q(w[i], x[i], y[i], z[i]);
    if (!std::isfinite(q.norm()) || q.norm() < 1e-9) {
      e.roll_deg.push_back(kNaN);
      e.pitch_deg.push_back(kNaN);
      e.yaw_deg.push_back(kNaN);
      continue;
    }
    const Eigen::Vector3d rpy = EulerFromQuat(q.normalized()) * kRadToDeg;
    e.roll_deg.push_back(rpy.x());
    e.pitch_deg.push_back(rpy.y());
    e.yaw_deg.push_back(rpy.z());
  }
  return e;
}

class Writer {
 public:
  Writer(std::string dir, std::vector<std::string>* written) : dir_(std::move(dir)), written_(written) {}
  template <class P>
  Status Write(const std::string& name, const P& plot, int w = kFigureWidth_px, int h = kFigureHeight_px) {
    Result<Image> image = Render(plot, w, h);
    if (!image.ok()) return image.status().WithContext(name);
    const std::string path = dir_ + "/" + name;
    HEXSIM_RETURN_IF_ERROR(WritePng(*image, path));
    if (written_) written_->push_back(path);
    return Status::Ok();
  }

 private:
  std::string dir_;
  std::vector<std::string>* written_;
};

Status TrackFigures(const logs::FlightLog& log, Writer& out) {
  std::vector<Track> tracks;
  auto add = [&](const char* name, const char* n, const char* e, const char* d) {
    if (!HasAll(log, {n, e})) return;
    Track t;
    t.name = name;
    t.north_m = log.Column(n);
    t.east_m = log.Column(e);
    if (HasData(log, d)) t.down_m = log.Column(d);
    tracks.push_back(std::move(t));
  };
  add("true", "pos_N_m", "pos_E_m", "pos_D_m");
  add("estimated", "est_pos_N_m", "est_pos_E_m", "est_pos_D_m");
  add("GPS", "gps_N_m", "gps_E_m", "gps_D_m");
  if (tracks.empty()) return Status::Ok();
  Track none;
  Plot2D top = TracksTopView(none, tracks);
  top.title = "Track (top view)";
  for (Series& s : top.series) {
    if (s.label == "GPS") {
      s.style = SeriesStyle::kScatter;
      s.marker_px = 2.5f;
      s.colour = Colour{0.5f, 0.5f, 0.5f, 0.6f};
    }
  }
  HEXSIM_RETURN_IF_ERROR(out.Write("track_top.png", top));
  Plot3D view = Tracks3D(none, tracks);
  view.title = "Track (3-D)";
  for (Series3D& s : view.series) {
    if (s.label == "GPS") {
      s.style = SeriesStyle::kScatter;
      s.marker_px = 2.0f;
      s.colour = Colour{0.5f, 0.5f, 0.5f, 0.6f};
    }
  }
  return out.Write("track_3d.png", view, 900, 760);
}


Status AltitudeFigure(const logs::FlightLog& log, Writer& out) {
  const std::vector<double>& t = log.Column("t_s");
  Plot2D p = TimePlot(log, "Altitude", "altitude (m)");
  if (HasData(log, "pos_D_m")) p.series.push_back(Line("true", t, Negated(log.Column("pos_D_m"))));
  if (HasData(log, "est_pos_D_m")) p.series.push_back(Line("estimated", t, Negated(log.Column("est_pos_D_m"))));
  if (HasData(log, "baro_alt_m")) p.series.push_back(Line("baro", t, log.Column("baro_alt_m")));
  if (HasData(log, "gps_D_m")) p.series.push_back(Line("GPS", t, Negated(log.Column("gps_D_m"))));
  if (!p.series.empty()) HEXSIM_RETURN_IF_ERROR(out.Write("altitude.png", p));
  return Status::Ok();
}

bool HasAttitude(const logs::FlightLog& log) { return HasAll(log, {"q_w", "q_x", "q_y", "q_z"}); }
bool HasEstimatedAttitude(const logs::FlightLog& log) { return HasAll(log, {"est_q_w", "est_q_x", "est_q_y", "est_q_z"}); }

// Roll, pitch and yaw of the attitude (q) and of the estimate (est_q), one panel each.
Status AttitudeFigure(const logs::FlightLog& log, Writer& out) {
  const bool has_q = HasAttitude(log), has_est_q = HasEstimatedAttitude(log);
  if (!has_q && !has_est_q) return Status::Ok();
  const std::vector<double>& t = log.Column("t_s");
  Figure f;
  f.title = "Attitude";
  f.rows = 3;
  const char* names[3] = {"roll (°)", "pitch (°)", "yaw (°)"};
  Euler truth, est;
  if (has_q) truth = EulerColumns(log, "q_");
  if (has_est_q) est = EulerColumns(log, "est_q_");
  for (int k = 0; k < 3; ++k) {
    Plot2D p = TimePlot(log, "", names[k]);
    if (k < 2) p.x_label.clear();
    auto pick = [k](const Euler& e) { return k == 0 ? e.roll_deg : (k == 1 ? e.pitch_deg : e.yaw_deg); };
    if (has_q) {
      Series s = Line("attitude (q)", t, pick(truth), PaletteColour(0));
      if (k == 2) BreakWraps(&s.x, &s.y);
      p.series.push_back(std::move(s));
    }
    if (has_est_q) {
      Series s = Line("estimate (est_q)", t, pick(est), PaletteColour(1));
      s.dashed = true;
      if (k == 2) BreakWraps(&s.x, &s.y);
      p.series.push_back(std::move(s));
    }
    if (k == 2) p.y_range = Range{-185.0, 185.0};
    if (k > 0) p.legend = LegendPosition::kNone;
    f.panels.emplace_back(p);
  }
  return out.Write("attitude.png", f, kFigureWidth_px, 900);
}

// Yaw error: logged yaw columns, else the estimate's quaternion against q.
Status YawErrorFigure(const logs::FlightLog& log, Writer& out) {
  const std::vector<double>& t = log.Column("t_s");
  std::vector<double> err;
  if (HasAll(log, {"yaw_est_deg", "yaw_true_deg"})) {
    const auto& e = log.Column("yaw_est_deg");
    const auto& tr = log.Column("yaw_true_deg");
    for (size_t i = 0; i < e.size(); ++i) err.push_back(WrapDeg180(e[i] - tr[i]));
  } else if (HasAttitude(log) && HasEstimatedAttitude(log)) {
    const Euler truth = EulerColumns(log, "q_"), est = EulerColumns(log, "est_q_");
    for (size_t i = 0; i < t.size(); ++i) err.push_back(WrapDeg180(est.yaw_deg[i] - truth.yaw_deg[i]));
  }
  for (double& v : err) {
    if (!std::isfinite(v)) v = kNaN;
  }
  if (err.empty()) return Status::Ok();
  Plot2D p = TimePlot(log, "Yaw error (estimated − true)", "yaw error (°)");
  p.series.push_back(Line("", t, err, PaletteColour(3)));
  p.ref_lines.push_back({RefLine::Axis::kHorizontal, 0.0, "", {0.3f, 0.3f, 0.3f, 1.0f}});
  p.legend = LegendPosition::kNone;
  return out.Write("yaw_error.png", p);
}

// Each compass' axes and field magnitude.
Status CompassFigures(const logs::FlightLog& log, Writer& out) {
  const std::vector<double>& t = log.Column("t_s");
  for (const char* prefix : {"mag", "mag2", "mag3", "mag4"}) {
    const std::string px = prefix;
    if (!HasAll(log, {(px + "_x_uT").c_str(), (px + "_y_uT").c_str(), (px + "_z_uT").c_str()})) continue;
    Figure f;
    f.title = "Compass " + px;
    f.rows = 2;
    Plot2D comp = TimePlot(log, "", "field (µT)");
    comp.x_label.clear();
    std::vector<double> norm(t.size());
    const auto& bx = log.Column(px + "_x_uT");
    const auto& by = log.Column(px + "_y_uT");
    const auto& bz = log.Column(px + "_z_uT");
    for (size_t i = 0; i < t.size(); ++i) norm[i] = std::sqrt(bx[i] * bx[i] + by[i] * by[i] + bz[i] * bz[i]);
    comp.series.push_back(Line("x", t, bx, PaletteColour(0)));
    comp.series.push_back(Line("y", t, by, PaletteColour(2)));
    comp.series.push_back(Line("z", t, bz, PaletteColour(3)));
    Plot2D mag = TimePlot(log, "", "|B| (µT)");
    mag.series.push_back(Line("|B|", t, norm, PaletteColour(4)));
    mag.legend = LegendPosition::kNone;
    f.panels = {comp, mag};
    HEXSIM_RETURN_IF_ERROR(out.Write("compass_" + px + ".png", f, kFigureWidth_px, 800));
  }
  return Status::Ok();
}

// Panels stacked one per row, the upper one without its time label; written when there is one.
Status WriteStacked(Figure f, const std::string& file, Writer& out) {
  f.rows = static_cast<int>(f.panels.size());
  if (f.rows == 2) std::get<Plot2D>(f.panels[0]).x_label.clear();
  if (f.panels.empty()) return Status::Ok();
  return out.Write(file, f, kFigureWidth_px, 360 * f.rows + 40);
}

// Current (battery and each motor) and voltage.
Status PowerFigure(const logs::FlightLog& log, Writer& out) {
  const std::vector<double>& t = log.Column("t_s");
  Figure f;
  f.title = "Electrical";
  Plot2D current = TimePlot(log, "", "current (A)");
  if (HasData(log, "current_A")) {
    Series s = Line("battery", t, log.Column("current_A"), Colour{0.13f, 0.13f, 0.13f, 1.0f});
    s.width_px = 2.0f;
    current.series.push_back(s);
  }
  for (int m = 1; m <= 12; ++m) {
    const std::string name = "motor_" + std::to_string(m) + "_A";
    if (HasData(log, name)) current.series.push_back(Line("motor " + std::to_string(m), t, log.Column(name)));
  }
  if (!current.series.empty()) f.panels.emplace_back(current);
  if (HasData(log, "voltage_V")) {
    Plot2D volt = TimePlot(log, "", "voltage (V)");
    volt.series.push_back(Line("bus voltage", t, log.Column("voltage_V"), PaletteColour(3)));
    volt.legend = LegendPosition::kNone;
    f.panels.emplace_back(volt);
  }
  return WriteStacked(std::move(f), "power.png", out);
}

// Motor commands and the collective.
Status MotorFigure(const logs::FlightLog& log, Writer& out) {
  const std::vector<double>& t = log.Column("t_s");
  Figure f;
  f.title = "Motor commands";
  Plot2D motors = TimePlot(log, "", "motor command (0…1)");
  for (int m = 1; m <= 12; ++m) {
    const std::string name = "motor_" + std::to_string(m) + "_u";
    if (HasData(log, name)) motors.series.push_back(Line("motor " + std::to_string(m), t, log.Column(name)));
  }
  if (!motors.series.empty()) f.panels.emplace_back(motors);
  if (HasData(log, "control_u")) {
    Plot2D u = TimePlot(log, "", "control amount (0…1000)");
    u.series.push_back(Line("control_u", t, log.Column("control_u"), Colour{0.13f, 0.13f, 0.13f, 1.0f}));
    u.legend = LegendPosition::kNone;
    f.panels.emplace_back(u);
  }
  return WriteStacked(std::move(f), "motors.png", out);
}

}  // namespace

Status RenderStandardFigures(const logs::FlightLog& log, const std::string& out_dir,
                             std::vector<std::string>* written) {
  if (!log.Has("t_s")) return Status::BadInput("plot: log has no t_s column");
  HEXSIM_RETURN_IF_ERROR(EnsureDirectory(out_dir));
  Writer out(out_dir, written);
  HEXSIM_RETURN_IF_ERROR(TrackFigures(log, out));
  HEXSIM_RETURN_IF_ERROR(AltitudeFigure(log, out));
  HEXSIM_RETURN_IF_ERROR(AttitudeFigure(log, out));
  HEXSIM_RETURN_IF_ERROR(YawErrorFigure(log, out));
  HEXSIM_RETURN_IF_ERROR(CompassFigures(log, out));
  HEXSIM_RETURN_IF_ERROR(PowerFigure(log, out));
  return MotorFigure(log, out);
}

Plot2D TracksTopView(const Track& planned, const std::vector<Track>& flown) {
  Plot2D p;
  p.title = "Track (top view)";
  p.x_label = "East (m)";
  p.y_label = "North (m)";
  p.equal_aspect = true;
  size_t k = 0;
  for (const Track& t : flown) {
    p.series.push_back(Line(t.name, t.east_m, t.north_m, t.colour ? t.colour : PaletteColour(k)));
    ++k;
  }
  // The planned path last, on top of the tracks that follow it.
  if (!planned.north_m.empty()) {
    Series s = Line(planned.name.empty() ? "planned" : planned.name, planned.east_m, planned.north_m,
                    planned.colour ? planned.colour : Colour{0.35f, 0.35f, 0.35f, 1.0f});
    s.dashed = true;
    s.style = SeriesStyle::kLineMarkers;
    s.marker_px = 6.0f;
    p.series.push_back(s);
  }
  return p;
}

Plot3D Tracks3D(const Track& planned, const std::vector<Track>& flown) {
  Plot3D p;
  p.title = "Track (3-D)";
  p.x_label = "East (m)";
  p.y_label = "North (m)";
  p.z_label = "altitude (m)";
  auto add = [&](const Track& t, Colour c, SeriesStyle style) {
    Series3D s;
    s.label = t.name;
    s.x = t.east_m;
    s.y = t.north_m;
    s.z = t.down_m.size() == t.north_m.size() ? Negated(t.down_m) : std::vector<double>(t.north_m.size(), 0.0);
    s.colour = c;
    s.style = style;
    s.marker_px = 5.0f;
    p.series.push_back(std::move(s));
  };
  size_t k = 0;
  for (const Track& t : flown) add(t, t.colour ? *t.colour : PaletteColour(k++), SeriesStyle::kLine);
  if (!planned.north_m.empty()) {  // last: on top
    Track named = planned;
    if (named.name.empty()) named.name = "planned";
    add(named, planned.colour ? *planned.colour : Colour{0.35f, 0.35f, 0.35f, 1.0f}, SeriesStyle::kLineMarkers);
  }
  return p;
}

Result<Image> RenderTracks(const Track& planned, const std::vector<Track>& flown, int width_px, int height_px) {
  Figure f;
  f.cols = 2;
  f.panels = {TracksTopView(planned, flown), Tracks3D(planned, flown)};
  return Render(f, width_px, height_px);
}

Plot2D HeadingResidualPlot(const std::vector<double>& angle_deg, const std::vector<NamedCurve>& error_deg) {
  Plot2D p;
  p.title = "Heading error over one turn";
  p.x_label = "table angle (°)";
  p.y_label = "heading error (°)";
  double lo = 0.0, hi = 360.0;
  for (double a : angle_deg) {
    if (std::isfinite(a)) {
      lo = std::min(lo, a);
      hi = std::max(hi, a);
    }
  }
  p.x_range = Range{lo, hi};
  for (const NamedCurve& c : error_deg) {
    Series s = Line(c.name, angle_deg, c.values);
    s.style = angle_deg.size() <= 72 ? SeriesStyle::kLineMarkers : SeriesStyle::kLine;
    p.series.push_back(std::move(s));
  }
  p.ref_lines.push_back({RefLine::Axis::kHorizontal, 0.0, "", {0.3f, 0.3f, 0.3f, 1.0f}});
  return p;
}

Result<Image> RenderHeadingResidual(const std::vector<double>& angle_deg, const std::vector<NamedCurve>& error_deg,
                                    int width_px, int height_px) {
  for (const NamedCurve& c : error_deg) {
    if (c.values.size() != angle_deg.size()) {
      return Status::BadInput("render: heading residual '" + c.name + "': length differs from angle_deg");
    }
  }
  return Render(HeadingResidualPlot(angle_deg, error_deg), width_px, height_px);
}

std::vector<std::array<double, 2>> ProjectedOutline(const Ellipsoid3D& e, int a, int b, int segments) {
  HEXSIM_CHECK(a >= 0 && a < 3 && b >= 0 && b < 3 && a != b && segments >= 3);
  // Projection of {c + M·u : |u| ≤ 1} onto (a, b) is {c_ab + L·v : |v| ≤ 1} with L·Lᵀ = P·M·Mᵀ·Pᵀ.
  auto dot = [](const Point3& p, const Point3& q) { return p[0] * q[0] + p[1] * q[1] + p[2] * q[2]; };
  const Point3& ra = e.shape[static_cast<size_t>(a)];
  const Point3& rb = e.shape[static_cast<size_t>(b)];
  const double s11 = dot(ra, ra), s12 = dot(ra, rb), s22 = dot(rb, rb);
  const double l11 = std::sqrt(s11);
  const double l21 = l11 > 0.0 ? s12 / l11 : 0.0;
  const double l22 = std::sqrt(std::max(0.0, s22 - l21 * l21));
  std::vector<std::array<double, 2>> out;
  for (int i = 0; i <= segments; ++i) {
    const double th = 2.0 * kPi * i / segments, c = std::cos(th), s = std::sin(th);
    out.push_back({e.centre[static_cast<size_t>(a)] + l11 * c, e.centre[static_cast<size_t>(b)] + l21 * c + l22 * s});
  }
  return out;
}

namespace {

const char* const kAxisNames[3] = {"x (µT)", "y (µT)", "z (µT)"};
const int kProjections[3][2] = {{0, 1}, {1, 2}, {0, 2}};

Plot2D Projection(int k, const char* title) {
  Plot2D p;
  p.title = std::string(title);
  p.x_label = kAxisNames[kProjections[k][0]];
  p.y_label = kAxisNames[kProjections[k][1]];
  p.equal_aspect = true;
  p.legend = LegendPosition::kNone;
  return p;
}

std::vector<double> Coord(const std::vector<Point3>& pts, int axis) {
  std::vector<double> out;
  out.reserve(pts.size());
  for (const Point3& p : pts) out.push_back(p[static_cast<size_t>(axis)]);
  return out;
}

}  // namespace

Result<Image> RenderEllipsoidClouds(const std::vector<SampleCloud>& clouds, const std::vector<Ellipsoid3D>& fits,
                                    int width_px, int height_px) {
  if (fits.size() > clouds.size()) return Status::BadInput("render: more ellipsoid fits than sample clouds");
  Figure f;
  f.rows = 2;
  f.cols = 2;
  Plot3D view;
  view.title = "Samples and fitted ellipsoids";
  view.x_label = kAxisNames[0];
  view.y_label = kAxisNames[1];
  view.z_label = kAxisNames[2];
  view.equal_aspect = true;
  Plot2D proj[3] = {Projection(0, "X–Y projection"), Projection(1, "Y–Z projection"), Projection(2, "X–Z projection")};
  for (size_t i = 0; i < clouds.size(); ++i) {
    const Colour c = clouds[i].colour ? *clouds[i].colour : PaletteColour(i);
    Colour faint = c;
    faint.a = 0.55f;
    Series3D s;
    s.label = clouds[i].label;
    s.x = Coord(clouds[i].points_uT, 0);
    s.y = Coord(clouds[i].points_uT, 1);
    s.z = Coord(clouds[i].points_uT, 2);
    s.style = SeriesStyle::kScatter;
    s.marker_px = 2.5f;
    s.colour = faint;
    view.series.push_back(s);
    for (int k = 0; k < 3; ++k) {
      Series ps;
      ps.x = Coord(clouds[i].points_uT, kProjections[k][0]);
      ps.y = Coord(clouds[i].points_uT, kProjections[k][1]);
      ps.style = SeriesStyle::kScatter;
      ps.marker_px = 2.5f;
      ps.colour = faint;
      proj[k].series.push_back(std::move(ps));
    }
    if (i < fits.size()) {
      Ellipsoid3D e = fits[i];
      e.colour = e.colour ? e.colour : c;
      view.ellipsoids.push_back(e);
      for (int k = 0; k < 3; ++k) {
        Series outline;
        for (const auto& p : ProjectedOutline(e, kProjections[k][0], kProjections[k][1])) {
          outline.x.push_back(p[0]);
          outline.y.push_back(p[1]);
        }
        outline.colour = c;
        outline.width_px = 1.8f;
        proj[k].series.push_back(std::move(outline));
        Series centre;
        centre.x = {e.centre[static_cast<size_t>(kProjections[k][0])]};
        centre.y = {e.centre[static_cast<size_t>(kProjections[k][1])]};
        centre.style = SeriesStyle::kScatter;
        centre.marker_px = 7.0f;
        centre.colour = c;
        proj[k].series.push_back(std::move(centre));
      }
    }
  }
  f.panels = {view, proj[0], proj[1], proj[2]};
  return Render(f, width_px, height_px);
}

Result<Image> RenderCentreLine(const std::vector<Point3>& centres_uT, const std::vector<std::string>& labels,
                               const Point3& line_point_uT, const Point3& line_direction, int width_px,
                               int height_px) {
  if (!labels.empty() && labels.size() != centres_uT.size()) {
    return Status::BadInput("render: centre line: labels and centres differ in number");
  }
  const double dn = std::sqrt(line_direction[0] * line_direction[0] + line_direction[1] * line_direction[1] +
                              line_direction[2] * line_direction[2]);
  if (!(dn > 0.0) || !std::isfinite(dn)) return Status::BadInput("render: centre line: direction must be non-zero");
  const Point3 d = {line_direction[0] / dn, line_direction[1] / dn, line_direction[2] / dn};
  // Span of the centres along the line, widened by 15 % each side.
  double smin = 0.0, smax = 0.0;
  for (size_t i = 0; i < centres_uT.size(); ++i) {
    double s = 0.0;
    for (size_t a = 0; a < 3; ++a) s += (centres_uT[i][a] - line_point_uT[a]) * d[a];
    smin = i == 0 ? s : std::min(smin, s);
    smax = i == 0 ? s : std::max(smax, s);
  }
  const double ext = 0.15 * std::max(smax - smin, 1.0);
  std::vector<Point3> line;
  for (double s : {smin - ext, smax + ext}) {
    line.push_back({line_point_uT[0] + s * d[0], line_point_uT[1] + s * d[1], line_point_uT[2] + s * d[2]});
  }
  Figure f;
  f.rows = 2;
  f.cols = 2;
  Plot3D view;
  view.title = "Ellipsoid centres and fitted line";
  view.x_label = kAxisNames[0];
  view.y_label = kAxisNames[1];
  view.z_label = kAxisNames[2];
  Series3D l3;
  l3.label = "fitted line";
  l3.x = Coord(line, 0);
  l3.y = Coord(line, 1);
  l3.z = Coord(line, 2);
  l3.colour = Colour{0.2f, 0.2f, 0.2f, 1.0f};
  view.series.push_back(l3);
  Plot2D proj[3] = {Projection(0, "X–Y projection"), Projection(1, "Y–Z projection"), Projection(2, "X–Z projection")};
  for (int k = 0; k < 3; ++k) {
    Series ls;
    ls.x = Coord(line, kProjections[k][0]);
    ls.y = Coord(line, kProjections[k][1]);
    ls.colour = Colour{0.2f, 0.2f, 0.2f, 1.0f};
    ls.dashed = true;
    proj[k].series.push_back(std::move(ls));
  }
  for (size_t i = 0; i < centres_uT.size(); ++i) {
    const Colour c = PaletteColour(i);
    Series3D s;
    s.label = labels.empty() ? "centre " + std::to_string(i + 1) : labels[i];
    s.x = {centres_uT[i][0]};
    s.y = {centres_uT[i][1]};
    s.z = {centres_uT[i][2]};
    s.style = SeriesStyle::kScatter;
    s.marker_px = 8.0f;
    s.colour = c;
    view.series.push_back(s);
    for (int k = 0; k < 3; ++k) {
      Series ps;
      ps.label = s.label;
      ps.x = {centres_uT[i][static_cast<size_t>(kProjections[k][0])]};
      ps.y = {centres_uT[i][static_cast<size_t>(kProjections[k][1])]};
      ps.style = SeriesStyle::kScatter;
      ps.marker_px = 8.0f;
      ps.colour = c;
      proj[k].series.push_back(std::move(ps));
    }
  }
  f.panels = {view, proj[0], proj[1], proj[2]};
  return Render(f, width_px, height_px);
}


std::string FlightModeLabel(const nlohmann::json& meta, double mode) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "mode %g", mode);
  std::string fallback = buf;
  if (!std::isfinite(mode) || mode != std::floor(mode) || std::fabs(mode) > 1e6) return fallback;
  const int n = static_cast<int>(mode);
  if (meta.is_object() && meta.contains("mode_names") && meta["mode_names"].is_object()) {
    const auto it = meta["mode_names"].find(std::to_string(n));
    if (it != meta["mode_names"].end() && it->is_string()) return it->get<std::string>();
  }
  const std::string format = meta.is_object() ? meta.value("format", "") : "";
  const std::string type = meta.is_object() ? meta.value("vehicle_type", "copter") : "";
  // Plane, Rover and Sub number their modes differently: only Copter's table is known here.
  const bool copter = type == "copter" || type == "unknown";
  const std::map<int, const char*>* names = format == "ardupilot-dataflash" && copter ? &kArduCopterModes
                                            : format == "px4-ulog"          ? &kPx4NavStates
                                                                            : nullptr;
  if (names == nullptr) return fallback;
  const auto it = names->find(n);
  return it == names->end() ? fallback : std::string(it->second);
}

}  // namespace hexsim::render
