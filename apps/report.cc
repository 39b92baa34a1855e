#include "report.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "compare_stats.h"
#include "hexsim/common/atomic_file.h"
#include "hexsim/common/paths.h"
#include "hexsim/common/yaml_reader.h"
#include "hexsim/control/sequencer.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/magnetics/compensator.h"
#include "hexsim/magnetics/ellipsoid_fit.h"
#include "hexsim/magnetics/heading_error.h"
#include "hexsim/magnetics/line_fit.h"
#include "hexsim/render/figures.h"
#include "hexsim/render/html.h"
#include "hexsim/render/paper_figures.h"
#include "hexsim/render/plot.h"
#include "hexsim/sim/run_config.h"
#include "hexsim/sim/turntable.h"
#include "turntable_util.h"

namespace hexsim::app {

namespace {

using nlohmann::json;

// The paper's Table 1 (heading residual after one turn, deg) at control amounts 0 / 200 / 300.
struct PaperRow {
  const char* method;
  double max_deg[3];
};
constexpr double kPaperControl_u[3] = {0.0, 200.0, 300.0};
constexpr PaperRow kPaperTable1[] = {
    {"none", {12.5, 13.3, 14.3}}, {"traditional", {2.5, 5.0, 7.6}}, {"adaptive", {2.4, 2.5, 2.6}}};
constexpr double kPaperCurrent_A[3] = {0.0, 32.0, 53.0};

// The turntable sessions the comparison used (cmd_compare.cc, calibration_setup.cc): the ground
// calibration is learnt from a session seeded from the first flight seed; Table 1 is evaluated on
// an independent level turn.
constexpr uint64_t kHeadingEvalSeed = 7919;
uint64_t CalibrationSessionSeed(uint64_t first_seed) { return first_seed * 1000003ULL + 17; }

std::optional<double> PaperValue(const std::string& method, double control_u) {
  for (const auto& row : kPaperTable1) {
    if (method != row.method) continue;
    for (int k = 0; k < 3; ++k) {
      if (std::fabs(control_u - kPaperControl_u[k]) < 0.5) return row.max_deg[k];
    }
  }
  return std::nullopt;
}

std::string Escape(const std::string& s) { return render::HtmlEscape(s); }

// A file-name-safe form of a calibration name (it may be a calib.yaml path).
std::string Slug(const std::string& s) {
  std::string o;
  for (char c : s) o += (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_') ? c : '_';
  return o;
}

std::string DisplayName(const std::string& calibration) { return calibration == "none" ? "uncorrected" : calibration; }

struct FigureEntry {
  std::string file, title, caption;
};

class FigureSink {
 public:
  explicit FigureSink(std::string dir) : dir_(std::move(dir)) {}
  Status Add(const Result<render::Image>& image, FigureEntry entry) {
    if (!image.ok()) return image.status().WithContext(entry.file);
    HEXSIM_RETURN_IF_ERROR(render::WritePng(*image, dir_ + "/" + entry.file));
    entries_.push_back(std::move(entry));
    return Status::Ok();
  }
  const std::vector<FigureEntry>& entries() const { return entries_; }

 private:
  std::string dir_;
  std::vector<FigureEntry> entries_;
};

// ---- The paper's turntable figures (Figs. 3–7) ---------------------------------------------------

std::vector<double> DistinctControls(const std::vector<magnetics::MagSample>& samples) {
  std::vector<double> u;
  for (const auto& s : samples) {
    if (std::none_of(u.begin(), u.end(), [&](double v) { return std::fabs(v - s.control_u) < 0.5; })) {
      u.push_back(s.control_u);
    }
  }
  std::sort(u.begin(), u.end());
  return u;
}

double MeanCurrent(const std::vector<magnetics::MagSample>& samples, double control_u) {
  double sum = 0.0;
  int n = 0;
  for (const auto& s : samples) {
    if (std::fabs(s.control_u - control_u) < 0.5) {
      sum += s.current_A;
      ++n;
    }
  }
  return n > 0 ? sum / n : 0.0;
}

Result<std::shared_ptr<const magnetics::Compensator>> CompensatorFor(const std::string& calibration,
                                                                     const std::vector<magnetics::MagSample>& ground) {
  if (calibration == "none") return std::shared_ptr<const magnetics::Compensator>(magnetics::MakeNoneCompensator());
  const auto names = magnetics::CompensatorNames();
  if (std::find(names.begin(), names.end(), calibration) != names.end()) {
    auto comp = magnetics::LearnCompensator(calibration, ground, magnetics::LearnOptions{}, nullptr);
    if (!comp.ok()) return comp.status().WithContext("report: " + calibration);
    return std::shared_ptr<const magnetics::Compensator>(std::move(*comp));
  }
  auto node = YamlReader::LoadFile(calibration);
  if (!node.ok()) return node.status();
  auto comp = magnetics::CompensatorFromYaml(*node, calibration);
  if (!comp.ok()) return comp.status();
  return std::shared_ptr<const magnetics::Compensator>(std::move(*comp));
}

render::Point3 ToPoint(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

// Fig. 3 and Fig. 4: per-control-amount ellipsoid fits of the ground session and the centres' line.
Status EllipsoidFigures(const std::vector<magnetics::MagSample>& ground, FigureSink* sink) {
  const std::vector<double> controls = DistinctControls(ground);
  std::vector<render::SampleCloud> clouds;
  std::vector<render::Ellipsoid3D> fits;
  std::vector<Eigen::Vector3d> centres;
  std::vector<std::string> labels;
  std::string residuals;
  for (double u : controls) {
    std::vector<Eigen::Vector3d> pts;
    std::set<std::string> planes;
    render::SampleCloud cloud;
    for (const auto& s : ground) {
      if (std::fabs(s.control_u - u) >= 0.5) continue;
      pts.push_back(s.mag_B_uT);
      cloud.points_uT.push_back(ToPoint(s.mag_B_uT));
      planes.insert(s.plane);
    }
    const std::string label = fmt::format("u = {:g} ({:.1f} A)", u, MeanCurrent(ground, u));
    magnetics::EllipsoidFitOptions opt;
    opt.planes_present = static_cast<int>(planes.size());
    const magnetics::EllipsoidFit fit = magnetics::FitEllipsoid(pts, opt);
    if (!fit.status.ok()) return fit.status.WithContext(fmt::format("report: ellipsoid fit at control {:g}", u));
    render::Ellipsoid3D e;
    e.centre = ToPoint(fit.hard_iron_uT);
    const Eigen::Matrix3d shape = fit.radius_uT * fit.soft_iron;  // {β + r·K·u : |u| = 1}
    for (int r = 0; r < 3; ++r) e.shape[static_cast<size_t>(r)] = ToPoint(shape.row(r).transpose());
    e.label = label;
    clouds.push_back(std::move(cloud));
    fits.push_back(e);
    centres.push_back(fit.hard_iron_uT);
    labels.push_back(label);
    residuals += fmt::format("{}{:g}: {:.1f} µT", residuals.empty() ? "" : ", ", u, fit.rms_residual_uT);
  }
  HEXSIM_RETURN_IF_ERROR(sink->Add(
      render::RenderEllipsoidClouds(clouds, fits, 1300, 1080),
      {"fig3_ellipsoids.png", "Fig. 3 — compass samples and fitted ellipsoids",
       fmt::format("Compass-1 samples from the simulated turntable (X-Y, Y-Z and X-Z turns) at each control amount "
                   "with the ellipsoid fitted to each (RMS geometric residual {}), in 3-D and projected on the "
                   "body planes; the ellipsoids keep their shape while their centres move with the motor current.",
                   residuals)}));
  if (centres.size() < 2) return Status::Ok();
  const magnetics::SvdLineFit line = magnetics::FitLineSvd(centres);
  if (!line.status.ok()) return line.status.WithContext("report: centre line");
  std::vector<render::Point3> c3;
  c3.reserve(centres.size());
  for (const auto& c : centres) c3.push_back(ToPoint(c));
  const double shift_uT = (centres.back() - centres.front()).norm();
  return sink->Add(
      render::RenderCentreLine(c3, labels, ToPoint(line.line.point_uT), ToPoint(line.line.direction), 1300, 1080),
      {"fig4_centre_line.png", "Fig. 4 — ellipsoid centres and the fitted space line",
       fmt::format("The ellipsoid centres (hard iron) at each control amount and the total-least-squares space line "
                   "through them (direction ({:.2f}, {:.2f}, {:.2f}), RMS distance {:.3f} µT); the centre moves "
                   "{:.1f} µT from the lowest to the highest control amount.",
                   line.line.direction.x(), line.line.direction.y(), line.line.direction.z(), line.rms_residual_uT,
                   shift_uT)});
}

// Figs. 5–7 (and one per further method): heading residual over a level turn, one curve per control
// amount. Also writes heading_residuals.csv with every point plotted.
Status HeadingFigures(const std::vector<std::string>& calibrations, const std::vector<magnetics::MagSample>& ground,
                      const std::vector<magnetics::MagSample>& turn, const std::string& out_dir, FigureSink* sink) {
  const std::vector<double> controls = DistinctControls(turn);
  std::string csv = "method,control_u,current_A,angle_deg,heading_error_deg\n";
  struct MethodCurves {
    std::string calibration;
    std::vector<double> angle_deg;
    std::vector<render::NamedCurve> curves;
    std::vector<double> max_abs_deg;
  };
  std::vector<MethodCurves> all;
  for (const auto& cal : calibrations) {
    auto comp = CompensatorFor(cal, ground);
    if (!comp.ok()) return comp.status();
    MethodCurves m;
    m.calibration = cal;
    for (double u : controls) {
      std::vector<std::pair<double, double>> pts;  // (angle, error)
      for (const auto& s : turn) {
        if (std::fabs(s.control_u - u) < 0.5) pts.emplace_back(s.angle_deg, magnetics::SampleHeadingErrorDeg(**comp, s));
      }
      std::sort(pts.begin(), pts.end());
      std::vector<double> angles, errs;
      double mx = 0.0;
      for (const auto& [a, e] : pts) {
        angles.push_back(a);
        errs.push_back(e);
        mx = std::max(mx, std::fabs(e));
        csv += fmt::format("{},{:g},{:.6g},{:g},{:.17g}\n", DisplayName(cal), u, MeanCurrent(turn, u), a, e);
      }
      if (m.angle_deg.empty()) m.angle_deg = angles;
      if (angles != m.angle_deg) return Status::BadInput("report: turntable turns differ in their table angles");
      m.curves.push_back({fmt::format("u = {:g} ({:.1f} A), max {:.2f}°", u, MeanCurrent(turn, u), mx), errs});
      m.max_abs_deg.push_back(mx);
    }
    all.push_back(std::move(m));
  }
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out_dir + "/heading_residuals.csv", csv));
  for (const auto& m : all) {
    render::Plot2D p = render::HeadingResidualPlot(m.angle_deg, m.curves);
    const std::string shown = DisplayName(m.calibration);
    p.title = "Heading residual over one level turn — " + shown;
    double lim = 1.0;
    for (double v : m.max_abs_deg) lim = std::max(lim, 1.15 * v);
    p.y_range = render::Range{-lim, lim};
    p.legend = render::LegendPosition::kBottomRight;
    std::string file, title;
    if (m.calibration == "none" || m.calibration == "traditional" || m.calibration == "adaptive") {
      const int n = m.calibration == "none" ? 5 : (m.calibration == "traditional" ? 6 : 7);
      file = fmt::format("fig{}_heading_{}.png", n, Slug(shown));
      title = fmt::format("Fig. {} — heading residual, {}", n, shown);
    } else {
      file = "heading_" + Slug(shown) + ".png";
      title = "Heading residual, " + shown;
    }
    std::string maxes;
    for (size_t k = 0; k < controls.size(); ++k) {
      maxes += fmt::format("{}{:.2f}°", k == 0 ? "" : " / ", m.max_abs_deg[k]);
    }
    std::string ctl;
    for (size_t k = 0; k < controls.size(); ++k) ctl += fmt::format("{}{:g}", k == 0 ? "" : "/", controls[k]);
    HEXSIM_RETURN_IF_ERROR(sink->Add(
        render::Render(p, render::kFigureWidth_px, render::kFigureHeight_px),
        {file, title,
         fmt::format("Heading error of the {} compass against the true heading over one 360° turn of the level "
                     "turntable at control amounts {} (largest |error| {}), on a turn independent of the one the "
                     "calibration was learnt from.",
                     m.calibration == "none" ? "uncorrected" : m.calibration + "-corrected", ctl, maxes)}));
  }
  return Status::Ok();
}

Status PaperFigures(const json& c, const std::vector<std::string>& calibrations, uint64_t first_seed,
                    const std::string& out_dir, FigureSink* sink) {
  auto vw = LoadVehicleAndWorld(c.at("vehicle").get<std::string>(), c.at("world").get<std::string>());
  if (!vw.ok()) return vw.status().WithContext("report");
  sim::TurntableOptions ground_opt;
  ground_opt.seed = CalibrationSessionSeed(first_seed);
  auto ground_rows = sim::RunTurntable(vw->vehicle, vw->world, ground_opt);
  if (!ground_rows.ok()) return ground_rows.status().WithContext("report: turntable");
  const auto ground = sim::ToMagSamples(*ground_rows, 0);
  HEXSIM_RETURN_IF_ERROR(EllipsoidFigures(ground, sink));
  sim::TurntableOptions eval_opt;
  eval_opt.planes = {"xy"};
  eval_opt.seed = kHeadingEvalSeed;
  if (c.contains("heading_error") && c["heading_error"].contains("control_u")) {
    eval_opt.control_u = c["heading_error"]["control_u"].get<std::vector<double>>();
  }
  auto eval_rows = sim::RunTurntable(vw->vehicle, vw->world, eval_opt);
  if (!eval_rows.ok()) return eval_rows.status().WithContext("report: turntable");
  return HeadingFigures(calibrations, ground, sim::ToMagSamples(*eval_rows, 0), out_dir, sink);
}

// ---- Flight figures (Figs. 8–9, yaw error, current) ----------------------------------------------

struct FlownRun {
  std::string calibration;
  uint64_t seed = 0;
  logs::FlightLog log;
};

// The planned path of the mission, started where the first log starts (the vehicle at rest).
std::optional<render::Track> PlannedTrack(const json& c, const logs::FlightLog& log) {
  if (!c.contains("mission") || !log.Has("pos_N_m") || !log.Has("pos_D_m") || log.rows() == 0) return std::nullopt;
  sim::RunRequest req;
  req.mission = c.at("mission").get<std::string>();
  if (c.contains("vehicle")) req.vehicle = c["vehicle"].get<std::string>();
  if (c.contains("world")) req.world = c["world"].get<std::string>();
  auto setup = sim::LoadRunSetup(req);
  if (!setup.ok()) return std::nullopt;
  const Eigen::Vector3d start(log.Column("pos_N_m")[0], log.Column("pos_E_m")[0], log.Column("pos_D_m")[0]);
  if (!start.allFinite()) return std::nullopt;
  render::Track t;
  t.name = "planned";
  for (const Eigen::Vector3d& p : control::PlannedPath(setup->mission, start, start.z())) {
    t.north_m.push_back(p.x());
    t.east_m.push_back(p.y());
    t.down_m.push_back(p.z());
  }
  return t;
}

std::string SummaryFigure(const json& summary, const char* key, const char* sub) {
  if (!summary.contains(key) || !summary[key].contains(sub)) return "–";
  return fmt::format("{:.2f}", summary[key][sub].get<double>());
}

Status FlightFigures(const json& c, const std::vector<FlownRun>& runs, FigureSink* sink) {
  if (runs.empty()) return Status::Ok();
  const std::optional<render::Track> planned = PlannedTrack(c, runs.front().log);
  const render::Track no_plan;
  std::vector<render::Track> all_tracks;
  int n = 0;
  for (const FlownRun& r : runs) {
    auto flown = render::LogTrack(r.log, DisplayName(r.calibration));
    if (!flown) continue;
    flown->colour = render::PaletteColour(static_cast<size_t>(n++));
    all_tracks.push_back(*flown);
    render::Figure f;
    f.cols = 2;
    f.title = fmt::format("Planned vs flown track — {} (seed {})", DisplayName(r.calibration), r.seed);
    render::Plot2D top = render::TracksTopView(planned ? *planned : no_plan, {*flown});
    top.title = "Top view";
    top.legend = render::LegendPosition::kBottomRight;
    render::Plot3D view = render::Tracks3D(planned ? *planned : no_plan, {*flown});
    view.title = "3-D view";
    view.legend = render::LegendPosition::kNone;
    f.panels = {top, view};
    json summary;
    for (const auto& run : c["runs"]) {
      if (run.value("calibration", "") == r.calibration && run.value("seed", uint64_t{0}) == r.seed) {
        summary = run.value("summary", json::object());
      }
    }
    HEXSIM_RETURN_IF_ERROR(sink->Add(
        render::Render(f, 1500, 700),
        {"tracks_" + Slug(r.calibration) + ".png",
         fmt::format("Figs. 8–9 — planned vs flown track, {}", DisplayName(r.calibration)),
         fmt::format("The mission's planned path (dashed, waypoints marked) and the true track flown with the {} "
                     "compass calibration (seed {}; cross-track error max {} m, RMS {} m), from above and in 3-D.",
                     DisplayName(r.calibration), r.seed, SummaryFigure(summary, "cross_track_m", "max"),
                     SummaryFigure(summary, "cross_track_m", "rms"))}));
  }
  if (all_tracks.size() > 1) {
    render::Plot2D top = render::TracksTopView(planned ? *planned : no_plan, all_tracks);
    top.title = "Planned path and every calibration's flown track (top view)";
    top.legend = render::LegendPosition::kBottomRight;
    HEXSIM_RETURN_IF_ERROR(sink->Add(
        render::Render(top, 1100, 900),
        {"tracks_all.png", "Flown tracks of every calibration",
         "The planned path with the true tracks of every calibration overlaid (first seed of each), seen from "
         "above, so their deviations from the path can be compared directly."}));
  }
  std::vector<render::TimeCurve> yaw;
  for (size_t i = 0; i < runs.size(); ++i) {
    std::vector<double> err = render::LogYawErrorDeg(runs[i].log);
    if (err.empty() || !runs[i].log.Has("t_s")) continue;
    yaw.push_back({DisplayName(runs[i].calibration), runs[i].log.Column("t_s"), std::move(err),
                   render::PaletteColour(i)});
  }
  if (!yaw.empty()) {
    render::Plot2D p = render::TimeOverlay("Yaw error during the mission (estimated − true)", "yaw error (°)", yaw, true);
    p.legend = render::LegendPosition::kTopRight;
    HEXSIM_RETURN_IF_ERROR(sink->Add(
        render::Render(p, render::kFigureWidth_px, render::kFigureHeight_px),
        {"yaw_error.png", "Yaw error vs time",
         fmt::format("The navigation estimate's yaw minus the true yaw through the mission for each calibration "
                     "(first seed of each, estimator {}): the compass error that reaches the heading estimate.",
                     c.value("estimator", std::string("eskf")))}));
  }
  const FlownRun& first = runs.front();
  if (first.log.Has("current_A") && first.log.Has("t_s")) {
    render::Figure f;
    f.rows = first.log.Has("control_u") ? 2 : 1;
    f.title = fmt::format("Battery current and control amount — {} (seed {})", DisplayName(first.calibration), first.seed);
    render::Plot2D cur = render::TimeOverlay("", "battery current (A)",
                                             {{"current", first.log.Column("t_s"), first.log.Column("current_A"),
                                               render::Colour{0.13f, 0.13f, 0.13f, 1.0f}}},
                                             false);
    f.panels.emplace_back(cur);
    if (f.rows == 2) {
      std::get<render::Plot2D>(f.panels[0]).x_label.clear();
      f.panels.emplace_back(render::TimeOverlay("", "control amount (0…1000)",
                                                {{"control_u", first.log.Column("t_s"), first.log.Column("control_u"),
                                                  render::PaletteColour(0)}},
                                                false));
    }
    HEXSIM_RETURN_IF_ERROR(sink->Add(
        render::Render(f, render::kFigureWidth_px, 380 * f.rows + 50),
        {"current.png", "Current vs time",
         fmt::format("Total battery current and the collective control amount through the mission flown with the {} "
                     "calibration: the current that drives the compass disturbance.",
                     DisplayName(first.calibration))}));
  }
  return Status::Ok();
}

// ---- HTML -------------------------------------------------------------------------------------------

constexpr const char* kCss = R"(body{font-family:"DejaVu Sans",Helvetica,Arial,sans-serif;max-width:1200px;margin:2em auto;
padding:0 1em;color:#222;line-height:1.45}h1{font-size:1.6em;margin-bottom:.2em}h2{font-size:1.25em;margin-top:2em;
border-bottom:1px solid #ccc;padding-bottom:.2em}p.meta{color:#555;margin-top:0}table{border-collapse:collapse;
margin:1em 0;font-size:.92em}th,td{border:1px solid #bbb;padding:.3em .6em;text-align:right}th{background:#f0f0f0}
td.name,th.name{text-align:left}td.paper{background:#f7f7ff;color:#335}.ci{color:#666;font-size:.85em}
.wrap{overflow-x:auto}figure{margin:1.5em 0}figure img{max-width:100%;border:1px solid #ddd}
figcaption{color:#444;font-size:.93em;margin-top:.3em}figcaption b{color:#222}.note{color:#555;font-size:.9em})";

std::string HeadingTable(const json& he) {
  const auto controls = he.at("control_u").get<std::vector<double>>();
  std::string h = "<div class=\"wrap\"><table id=\"heading-error\">\n<tr><th class=\"name\" rowspan=\"2\">method</th>";
  for (const double control : controls) h += fmt::format("<th colspan=\"3\">control {:g}</th>", control);
  h += "</tr>\n<tr>";
  for (size_t k = 0; k < controls.size(); ++k) h += "<th>max (°)</th><th>RMS (°)</th><th>paper max (°)</th>";
  h += "</tr>\n";
  for (const auto& row : he.at("rows")) {
    const std::string method = row.value("method", row.value("name", ""));
    const auto mx = row.at("max_deg").get<std::vector<double>>();
    const auto rms = row.at("rms_deg").get<std::vector<double>>();
    h += fmt::format("<tr><td class=\"name\">{}</td>", Escape(row.value("name", method)));
    for (size_t k = 0; k < controls.size(); ++k) {
      const auto paper = PaperValue(method, controls[k]);
      h += fmt::format("<td>{:.2f}</td><td>{:.2f}</td><td class=\"paper\">{}</td>", k < mx.size() ? mx[k] : NAN,
                       k < rms.size() ? rms[k] : NAN, paper ? fmt::format("{:.1f}", *paper) : "–");
    }
    h += "</tr>\n";
  }
  h += "<tr><td class=\"name\">battery current (A)</td>";
  std::vector<double> cur;
  for (const auto& row : he.at("rows")) {
    if (row.contains("current_A")) {
      cur = row["current_A"].get<std::vector<double>>();
      break;
    }
  }
  for (size_t k = 0; k < controls.size(); ++k) {
    std::string paper = "–";
    for (int j = 0; j < 3; ++j) {
      if (std::fabs(controls[k] - kPaperControl_u[j]) < 0.5) paper = fmt::format("{:g}", kPaperCurrent_A[j]);
    }
    h += fmt::format("<td colspan=\"2\">{}</td><td class=\"paper\">{}</td>",
                     k < cur.size() ? fmt::format("{:.1f}", cur[k]) : "–", paper);
  }
  h += "</tr>\n</table></div>\n";
  return h;
}

const std::map<std::string, std::string>& MetricTitles() {
  static const std::map<std::string, std::string> k = {
      {"yaw_error_deg.max", "yaw error max (°)"}, {"yaw_error_deg.rms", "yaw error RMS (°)"},
      {"cross_track_m.max", "cross-track max (m)"}, {"cross_track_m.rms", "cross-track RMS (m)"},
      {"energy_Wh", "energy (Wh)"},               {"mission_time_s", "mission time (s)"},
      {"distance_m", "distance (m)"},             {"current_A.mean", "current mean (A)"},
      {"current_A.max", "current max (A)"}};
  return k;
}

std::string TrackTable(const json& groups) {
  std::vector<std::string> metrics;
  for (const auto& f : SummaryFigures()) {
    for (const auto& g : groups) {
      if (g.contains("metrics") && g["metrics"].contains(f)) {
        metrics.push_back(f);
        break;
      }
    }
  }
  std::string h = "<div class=\"wrap\"><table id=\"track-error\">\n<tr><th class=\"name\">calibration</th><th>n</th>";
  for (const auto& m : metrics) {
    const auto it = MetricTitles().find(m);
    h += "<th>" + Escape(it != MetricTitles().end() ? it->second : m) + "</th>";
  }
  h += "</tr>\n";
  for (const auto& g : groups) {
    h += fmt::format("<tr><td class=\"name\">{}</td><td>{}</td>", Escape(DisplayName(g.at("calibration"))),
                     g.value("n", 0));
    for (const auto& m : metrics) {
      if (!g["metrics"].contains(m)) {
        h += "<td>–</td>";
        continue;
      }
      const json& v = g["metrics"][m];
      std::string ci;
      if (v.contains("ci95") && v["ci95"].is_array() && v["ci95"].size() == 2 && v["ci95"][0].is_number() &&
          v["ci95"][1].is_number()) {
        ci = fmt::format("<br><span class=\"ci\">CI95 [{:.2f}, {:.2f}]</span>", v["ci95"][0].get<double>(),
                         v["ci95"][1].get<double>());
      } else {
        ci = "<br><span class=\"ci\">CI95 –</span>";
      }
      h += fmt::format("<td>{:.2f} ± {:.2f}{}</td>", v.at("mean").get<double>(), v.value("std", 0.0), ci);
    }
    h += "</tr>\n";
  }
  h += "</table></div>\n";
  return h;
}

std::string FigureHtml(const FigureEntry& f) {
  return fmt::format("<figure><img src=\"{0}\" alt=\"{1}\"><figcaption><b>{1}.</b> {2}</figcaption></figure>\n",
                     Escape(f.file), Escape(f.title), Escape(f.caption));
}

Status WriteReport(const json& c, const std::string& out_dir) {
  if (!c.contains("groups") || !c["groups"].is_array()) return Status::BadInput("report: comparison has no groups");
  std::vector<std::string> calibrations;
  for (const auto& g : c["groups"]) calibrations.push_back(g.at("calibration").get<std::string>());

  // First seed of each calibration, and the overall first seed (the one the ground calibration used).
  std::map<std::string, uint64_t> first_seed;
  uint64_t seed0 = 1;
  bool any = false;
  for (const auto& r : c.value("runs", json::array())) {
    const std::string cal = r.at("calibration").get<std::string>();
    const uint64_t seed = r.at("seed").get<uint64_t>();
    if (!first_seed.count(cal) || seed < first_seed[cal]) first_seed[cal] = seed;
    seed0 = any ? std::min(seed0, seed) : seed;
    any = true;
  }

  FigureSink figures(out_dir);
  if (c.contains("vehicle") && c.contains("world")) {
    HEXSIM_RETURN_IF_ERROR(PaperFigures(c, calibrations, seed0, out_dir, &figures));
  }
  std::vector<FlownRun> runs;
  for (const auto& cal : calibrations) {
    if (!first_seed.count(cal)) continue;
    const std::string path = fmt::format("{}/{}/seed_{}/log.csv", out_dir, cal, first_seed[cal]);
    auto log = logs::ReadFlightLog(path);
    if (!log.ok()) return log.status();
    runs.push_back({cal, first_seed[cal], std::move(*log)});
  }
  HEXSIM_RETURN_IF_ERROR(FlightFigures(c, runs, &figures));

  std::string h = "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<title>hexsim comparison: " +
                  Escape(c.value("mission", "")) + "</title>\n<style>" + kCss + "</style></head><body>\n";
  h += fmt::format("<h1>Compass calibration comparison — {}</h1>\n", Escape(c.value("mission", "")));
  h += fmt::format(
      "<p class=\"meta\">vehicle <b>{}</b>, world <b>{}</b>, estimator <b>{}</b>, {} run(s). Data beside this file: "
      "<a href=\"comparison.json\">comparison.json</a>, <a href=\"heading_residuals.csv\">heading_residuals.csv</a>, "
      "and each run's <code>&lt;calibration&gt;/seed_&lt;n&gt;/log.csv</code>.</p>\n",
      Escape(c.value("vehicle", "")), Escape(c.value("world", "")), Escape(c.value("estimator", "")),
      c.value("runs", json::array()).size());

  if (c.contains("heading_error")) {
    h += "<h2>Heading error on the turntable (the paper's Table 1)</h2>\n";
    h += "<p>Largest |heading error| (and its RMS) over one full level turn at each control amount, for each "
         "calibration learnt on the simulated turntable, next to the paper's published maxima (Xu et al. 2016, "
         "Table 1: uncorrected, traditional ellipsoid, adaptive).</p>\n";
    h += HeadingTable(c["heading_error"]);
  }
  h += "<h2>Flight: track and yaw error per calibration</h2>\n";
  h += "<p>Mean ± standard deviation over the seeds, with the 95 % confidence interval of the mean (Student's t; "
       "empty with one seed).</p>\n";
  h += TrackTable(c["groups"]);

  auto section = [&](const std::string& title, auto pred) {
    std::string body;
    for (const auto& f : figures.entries()) {
      if (pred(f.file)) body += FigureHtml(f);
    }
    if (!body.empty()) h += "<h2>" + Escape(title) + "</h2>\n" + body;
  };
  auto starts = [](const std::string& s, const char* p) { return s.rfind(p, 0) == 0; };
  section("Ground calibration (Figs. 3–4)", [&](const std::string& f) { return starts(f, "fig3") || starts(f, "fig4"); });
  section("Heading residual on the turntable (Figs. 5–7)", [&](const std::string& f) {
    return starts(f, "fig5") || starts(f, "fig6") || starts(f, "fig7") || starts(f, "heading_");
  });
  section("Flown tracks (Figs. 8–9)", [&](const std::string& f) { return starts(f, "tracks_"); });
  section("Yaw error and current during the mission",
          [&](const std::string& f) { return f == "yaw_error.png" || f == "current.png"; });
  h += "<p class=\"note\">Generated by hexsim " + Escape(Version()) +
       ". The turntable figures are regenerated from the same sessions the comparison used: the ground "
       "calibration session seeded from the first flight seed, and an independent level turn for the heading "
       "residuals.</p>\n</body></html>\n";
  return WriteFileAtomic(out_dir + "/report.html", h);
}

}  // namespace

Status WriteCompareReport(const nlohmann::json& comparison, const std::string& out_dir) {
  try {
    return WriteReport(comparison, out_dir);
  } catch (const nlohmann::json::exception& e) {
    return Status::BadInput(std::string("report: malformed comparison JSON: ") + e.what());
  }
}

}  // namespace hexsim::app
