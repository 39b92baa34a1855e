#include "hexsim/render/paper_figures.h"

#include <cmath>
#include <limits>

#include <Eigen/Geometry>

#include "hexsim/common/rotation.h"

namespace hexsim::render {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool HasData(const logs::FlightLog& log, const std::string& name) {
  if (!log.Has(name)) return false;
  for (double v : log.Column(name)) {
    if (std::isfinite(v)) return true;
  }
  return false;
}

// Yaw (deg) of the quaternion columns <prefix>w..z; NaN where missing or degenerate.
std::vector<double> YawColumnDeg(const logs::FlightLog& log, const std::string& prefix) {
  const auto& w = log.Column(prefix + "w");
  const auto& x = log.Column(prefix + "x");
  const auto& y = log.Column(prefix + "y");
  const auto& z = log.Column(prefix + "z");
  std::vector<double> yaw(w.size(), kNaN);
  for (size_t i = 0; i < w.size(); ++i) {
    const Eigen::Quaterniond q(w[i], x[i], y[i], z[i]);
    const double n = q.norm();
    if (std::isfinite(n) && n > 1e-9) yaw[i] = EulerFromQuat(q.normalized()).z() * kRadToDeg;
  }
  return yaw;
}

bool HasQuat(const logs::FlightLog& log, const std::string& prefix) {
  for (const char* c : {"w", "x", "y", "z"}) {
    if (!HasData(log, prefix + c)) return false;
  }
  return true;
}

}  // namespace

std::vector<double> LogYawErrorDeg(const logs::FlightLog& log) {
  std::vector<double> est, truth;
  if (HasData(log, "yaw_est_deg") && HasData(log, "yaw_true_deg")) {
    est = log.Column("yaw_est_deg");
    truth = log.Column("yaw_true_deg");
  } else if (HasQuat(log, "q_") && HasQuat(log, "est_q_")) {
    est = YawColumnDeg(log, "est_q_");
    truth = YawColumnDeg(log, "q_");
  } else {
    return {};
  }
  std::vector<double> err(est.size(), kNaN);
  for (size_t i = 0; i < est.size(); ++i) {
    if (std::isfinite(est[i]) && std::isfinite(truth[i])) err[i] = WrapDeg180(est[i] - truth[i]);
  }
  return err;
}

std::optional<Track> LogTrack(const logs::FlightLog& log, const std::string& name) {
  if (!HasData(log, "pos_N_m") || !HasData(log, "pos_E_m")) return std::nullopt;
  Track t;
  t.name = name;
  t.north_m = log.Column("pos_N_m");
  t.east_m = log.Column("pos_E_m");
  if (HasData(log, "pos_D_m")) t.down_m = log.Column("pos_D_m");
  return t;
}

Plot2D TimeOverlay(const std::string& title, const std::string& y_label, const std::vector<TimeCurve>& curves,
                   bool zero_line) {
  Plot2D p;
  p.title = title;
  p.x_label = "time (s)";
  p.y_label = y_label;
  for (size_t i = 0; i < curves.size(); ++i) {
    Series s;
    s.label = curves[i].name;
    s.x = curves[i].t_s;
    s.y = curves[i].values;
    s.colour = curves[i].colour ? curves[i].colour : PaletteColour(i);
    s.width_px = 1.8f;
    p.series.push_back(std::move(s));
  }
  if (zero_line) p.ref_lines.push_back({RefLine::Axis::kHorizontal, 0.0, "", {0.3f, 0.3f, 0.3f, 1.0f}});
  p.legend = curves.size() > 1 ? LegendPosition::kTopRight : LegendPosition::kNone;
  return p;
}

Status RenderLogOverlays(const std::vector<const logs::FlightLog*>& logs, const std::vector<std::string>& names,
                         const std::string& out_dir, std::vector<std::string>* written) {
  if (logs.size() != names.size()) return Status::BadInput("plot: one name per log");
  std::vector<Track> tracks;
  std::vector<TimeCurve> yaw;
  for (size_t i = 0; i < logs.size(); ++i) {
    const logs::FlightLog& log = *logs[i];
    if (auto t = LogTrack(log, names[i])) {
      t->colour = PaletteColour(i);
      tracks.push_back(std::move(*t));
    }
    std::vector<double> err = LogYawErrorDeg(log);
    if (!err.empty() && log.Has("t_s")) yaw.push_back({names[i], log.Column("t_s"), std::move(err), PaletteColour(i)});
  }
  if (!tracks.empty()) {
    Figure f;
    f.cols = 2;
    f.title = "Flown tracks";
    Plot2D top = TracksTopView(Track{}, tracks);
    top.title = "Top view";
    Plot3D view = Tracks3D(Track{}, tracks);
    view.title = "3-D view";
    view.legend = LegendPosition::kNone;
    f.panels = {top, view};
    auto image = Render(f, 1500, 700);
    if (!image.ok()) return image.status().WithContext("overlay_tracks.png");
    HEXSIM_RETURN_IF_ERROR(WritePng(*image, out_dir + "/overlay_tracks.png"));
    if (written) written->push_back(out_dir + "/overlay_tracks.png");
  }
  if (!yaw.empty()) {
    const Plot2D p = TimeOverlay("Yaw error (estimated − true)", "yaw error (°)", yaw, true);
    auto image = Render(p, kFigureWidth_px, kFigureHeight_px);
    if (!image.ok()) return image.status().WithContext("overlay_yaw_error.png");
    HEXSIM_RETURN_IF_ERROR(WritePng(*image, out_dir + "/overlay_yaw_error.png"));
    if (written) written->push_back(out_dir + "/overlay_yaw_error.png");
  }
  return Status::Ok();
}

}  // namespace hexsim::render
