#include "hexsim/reports/compare_report.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "hexsim/common/atomic_file.h"
#include "hexsim/common/paths.h"
#include "hexsim/render/figures.h"
#include "hexsim/render/html.h"
#include "hexsim/render/paper_figures.h"
#include "hexsim/render/plot.h"
#include "hexsim/reports/headline.h"

namespace hexsim::reports {

namespace {

using experiments::Comparison;
using experiments::CompareEvidence;

// The paper's Table 1 (heading residual after one turn, deg) at control amounts 0 / 200 / 300.
struct PaperRow {
  const char* method;
  double max_deg[3];
};
constexpr double kPaperControl_u[3] = {0.0, 200.0, 300.0};
constexpr PaperRow kPaperTable1[] = {
    {"none", {12.5, 13.3, 14.3}}, {"traditional", {2.5, 5.0, 7.6}}, {"adaptive", {2.4, 2.5, 2.6}}};
constexpr double kPaperCurrent_A[3] = {0.0, 32.0, 53.0};

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

render::Point3 ToPoint(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

// ---- The paper's turntable figures (Figs. 3–7) ---------------------------------------------------

// Fig. 3 and Fig. 4: per-control-amount ellipsoid fits of the ground session and the centres' line.
Status EllipsoidFigures(const experiments::GroundSessionFits& g, FigureSink* sink) {
  std::vector<render::SampleCloud> clouds;
  std::vector<render::Ellipsoid3D> fits;
  std::vector<render::Point3> centres;
  std::vector<std::string> labels;
  std::string residuals;
  for (const auto& c : g.per_control) {
    render::SampleCloud cloud;
    for (const auto& m : c.mag_B_uT) cloud.points_uT.push_back(ToPoint(m));
    const std::string label = fmt::format("u = {:g} ({:.1f} A)", c.control_u, c.mean_current_A);
    render::Ellipsoid3D e;
    e.centre = ToPoint(c.fit.hard_iron_uT);
    const Eigen::Matrix3d shape = c.fit.radius_uT * c.fit.soft_iron;  // {β + r·K·u : |u| = 1}
    for (int r = 0; r < 3; ++r) e.shape[static_cast<size_t>(r)] = ToPoint(shape.row(r).transpose());
    e.label = label;
    clouds.push_back(std::move(cloud));
    fits.push_back(e);
    centres.push_back(ToPoint(c.fit.hard_iron_uT));
    labels.push_back(label);
    residuals += fmt::format("{}{:g}: {:.1f} µT", residuals.empty() ? "" : ", ", c.control_u, c.fit.rms_residual_uT);
  }
  HEXSIM_RETURN_IF_ERROR(sink->Add(
      render::RenderEllipsoidClouds(clouds, fits, 1300, 1080),
      {"fig3_ellipsoids.png", "Fig. 3 — compass samples and fitted ellipsoids",
       fmt::format("Compass-1 samples from the simulated turntable (X-Y, Y-Z and X-Z turns) at each control amount "
                   "with the ellipsoid fitted to each (RMS geometric residual {}), in 3-D and projected on the "
                   "body planes; the ellipsoids keep their shape while their centres move with the motor current.",
                   residuals)}));
  if (!g.has_line) return Status::Ok();
  const magnetics::SvdLineFit& line = g.line;
  const double shift_uT =
      (g.per_control.back().fit.hard_iron_uT - g.per_control.front().fit.hard_iron_uT).norm();
  return sink->Add(
      render::RenderCentreLine(centres, labels, ToPoint(line.line.point_uT), ToPoint(line.line.direction), 1300, 1080),
      {"fig4_centre_line.png", "Fig. 4 — ellipsoid centres and the fitted space line",
       fmt::format("The ellipsoid centres (hard iron) at each control amount and the total-least-squares space line "
                   "through them (direction ({:.2f}, {:.2f}, {:.2f}), RMS distance {:.3f} µT); the centre moves "
                   "{:.1f} µT from the lowest to the highest control amount.",
                   line.line.direction.x(), line.line.direction.y(), line.line.direction.z(), line.rms_residual_uT,
                   shift_uT)});
}

// Figs. 5–7 (and one per further method): heading residual over a level turn, one curve per control
// amount. Also writes heading_residuals.csv with every point plotted.
Status HeadingFigures(const std::vector<experiments::HeadingCurves>& all, const std::string& out_dir,
                      FigureSink* sink) {
  std::string csv = "method,control_u,current_A,angle_deg,heading_error_deg\n";
  for (const auto& m : all) {
    for (size_t k = 0; k < m.control_u.size(); ++k) {
      for (size_t i = 0; i < m.angle_deg.size(); ++i) {
        csv += fmt::format("{},{:g},{:.6g},{:g},{:.17g}\n", DisplayName(m.calibration), m.control_u[k], m.current_A[k],
                           m.angle_deg[i], m.error_deg[k][i]);
      }
    }
  }
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out_dir + "/heading_residuals.csv", csv));
  for (const auto& m : all) {
    std::vector<render::NamedCurve> curves;
    for (size_t k = 0; k < m.control_u.size(); ++k) {
      curves.push_back({fmt::format("u = {:g} ({:.1f} A), max {:.2f}°", m.control_u[k], m.current_A[k],
                                    m.max_abs_deg[k]),
                        m.error_deg[k]});
    }
    render::Plot2D p = render::HeadingResidualPlot(m.angle_deg, curves);
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
    for (size_t k = 0; k < m.control_u.size(); ++k) {
      maxes += fmt::format("{}{:.2f}°", k == 0 ? "" : " / ", m.max_abs_deg[k]);
    }
    std::string ctl;
    for (size_t k = 0; k < m.control_u.size(); ++k) ctl += fmt::format("{}{:g}", k == 0 ? "" : "/", m.control_u[k]);
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

// ---- Flight figures (Figs. 8–9, yaw error, current) ----------------------------------------------

std::string Figure2(double v) { return fmt::format("{:.2f}", v); }

Status FlightFigures(const Comparison& c, const CompareEvidence& ev, FigureSink* sink) {
  const std::vector<experiments::FlownRun>& runs = ev.first_flights;
  if (runs.empty()) return Status::Ok();
  std::optional<render::Track> planned;
  if (ev.planned_path_N_m) {
    planned.emplace();
    planned->name = "planned";
    for (const Eigen::Vector3d& p : *ev.planned_path_N_m) {
      planned->north_m.push_back(p.x());
      planned->east_m.push_back(p.y());
      planned->down_m.push_back(p.z());
    }
  }
  const render::Track no_plan;
  std::vector<render::Track> all_tracks;
  int n = 0;
  for (const experiments::FlownRun& r : runs) {
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
    std::string xt_max = "–", xt_rms = "–";
    for (const auto& run : c.runs) {
      if (run.calibration == r.calibration && run.seed == r.seed) {
        xt_max = Figure2(run.summary.cross_track_m.max);
        xt_rms = Figure2(run.summary.cross_track_m.rms);
      }
    }
    HEXSIM_RETURN_IF_ERROR(sink->Add(
        render::Render(f, 1500, 700),
        {"tracks_" + Slug(r.calibration) + ".png",
         fmt::format("Figs. 8–9 — planned vs flown track, {}", DisplayName(r.calibration)),
         fmt::format("The mission's planned path (dashed, waypoints marked) and the true track flown with the {} "
                     "compass calibration (seed {}; cross-track error max {} m, RMS {} m), from above and in 3-D.",
                     DisplayName(r.calibration), r.seed, xt_max, xt_rms)}));
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
                     c.estimator)}));
  }
  const experiments::FlownRun& first = runs.front();
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
figcaption{color:#444;font-size:.93em;margin-top:.3em}figcaption b{color:#222}.note{color:#555;font-size:.9em}
.headline{background:#f4f8fc;border-left:4px solid #1f77b4;padding:.2em 1em;margin:1em 0}.headline p{margin:.5em 0})";

std::string HeadingTable(const experiments::HeadingErrorTable& he) {
  const std::vector<double>& controls = he.control_u;
  std::string h = "<div class=\"wrap\"><table id=\"heading-error\">\n<tr><th class=\"name\" rowspan=\"2\">method</th>";
  for (const double control : controls) h += fmt::format("<th colspan=\"3\">control {:g}</th>", control);
  h += "</tr>\n<tr>";
  for (size_t k = 0; k < controls.size(); ++k) h += "<th>max (°)</th><th>RMS (°)</th><th>paper max (°)</th>";
  h += "</tr>\n";
  for (const auto& row : he.rows) {
    const std::vector<double>& mx = row.max_deg;
    const std::vector<double>& rms = row.rms_deg;
    h += fmt::format("<tr><td class=\"name\">{}</td>", Escape(row.name));
    for (size_t k = 0; k < controls.size(); ++k) {
      const auto paper = PaperValue(row.method, controls[k]);
      h += fmt::format("<td>{:.2f}</td><td>{:.2f}</td><td class=\"paper\">{}</td>", k < mx.size() ? mx[k] : NAN,
                       k < rms.size() ? rms[k] : NAN, paper ? fmt::format("{:.1f}", *paper) : "–");
    }
    h += "</tr>\n";
  }
  h += "<tr><td class=\"name\">battery current (A)</td>";
  const std::vector<double> cur = he.rows.empty() ? std::vector<double>{} : he.rows.front().current_A;
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

std::string TrackTable(const std::vector<experiments::ComparisonGroup>& groups) {
  std::vector<std::string> metrics;
  for (const auto& f : experiments::SummaryFigures()) {
    for (const auto& g : groups) {
      if (g.metrics.count(f.path)) {
        metrics.emplace_back(f.path);
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
    h += fmt::format("<tr><td class=\"name\">{}</td><td>{}</td>", Escape(DisplayName(g.calibration)), g.n);
    for (const auto& m : metrics) {
      const auto it = g.metrics.find(m);
      if (it == g.metrics.end()) {
        h += "<td>–</td>";
        continue;
      }
      const SampleStats& v = it->second;
      // One run: the interval collapses onto the mean (as comparison.json writes it).
      const std::string ci = fmt::format("<br><span class=\"ci\">CI95 [{:.2f}{}, {:.2f}]</span>",
                                         v.ci95_lo.value_or(v.mean), v.ci95_clipped ? "*" : "",
                                         v.ci95_hi.value_or(v.mean));
      h += fmt::format("<td>{:.2f} ± {:.2f}{}</td>", v.mean, v.std.value_or(0.0), ci);
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

Status WriteReport(const Comparison& c, const CompareEvidence& ev, const std::string& out_dir) {
  FigureSink figures(out_dir);
  HEXSIM_RETURN_IF_ERROR(EllipsoidFigures(ev.ground_fits, &figures));
  HEXSIM_RETURN_IF_ERROR(HeadingFigures(ev.heading, out_dir, &figures));
  HEXSIM_RETURN_IF_ERROR(FlightFigures(c, ev, &figures));

  std::string h = "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<title>hexsim comparison: " +
                  Escape(c.mission) + "</title>\n<style>" + kCss + "</style></head><body>\n";
  h += fmt::format("<h1>Compass calibration comparison — {}</h1>\n", Escape(c.mission));
  h += "<div class=\"headline\">";
  for (const std::string& sentence : CompareHeadline(c)) h += "<p>" + Escape(sentence) + "</p>";
  h += "</div>\n";
  h += fmt::format(
      "<p class=\"meta\">vehicle <b>{}</b>, world <b>{}</b>, estimator <b>{}</b>, {} run(s). Data beside this file: "
      "<a href=\"comparison.json\">comparison.json</a>, <a href=\"heading_residuals.csv\">heading_residuals.csv</a>, "
      "and each run's <code>&lt;calibration&gt;/seed_&lt;n&gt;/log.csv</code>.</p>\n",
      Escape(c.vehicle), Escape(c.world), Escape(c.estimator), c.runs.size());

  {
    h += "<h2>Heading error on the turntable (the paper's Table 1)</h2>\n";
    h += "<p>Largest |heading error| (and its RMS) over one full level turn at each control amount, for each "
         "calibration learnt on the simulated turntable, next to the paper's published maxima (Xu et al. 2016, "
         "Table 1: uncorrected, traditional ellipsoid, adaptive).</p>\n";
    h += HeadingTable(c.heading_error);
  }
  h += "<h2>Flight: track and yaw error per calibration</h2>\n";
  h += "<p>Mean ± standard deviation over the seeds, with the 95 % confidence interval of the mean (Student's t; "
       "empty with one seed; * marks a lower end clipped at 0, below which no error, distance or energy goes).</p>\n";
  h += TrackTable(c.groups);

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

Status WriteCompareReport(const experiments::Comparison& comparison, const experiments::CompareEvidence& evidence,
                          const std::string& out_dir) {
  return WriteReport(comparison, evidence, out_dir);
}

}  // namespace hexsim::reports
