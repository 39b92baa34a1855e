#include "hexsim/reports/batch_report.h"

#include <limits>

#include <fmt/format.h>

#include "hexsim/render/image.h"
#include "hexsim/render/plot.h"

namespace hexsim::reports {

namespace {

render::Plot2D MetricPlot(const std::vector<batch::GroupReport>& groups, const std::string& metric,
                          const std::string& title) {
  render::Plot2D plot;
  plot.title = title;
  plot.x_label = "group (numbered as in the table)";
  plot.y_label = metric;
  plot.legend = render::LegendPosition::kTopRight;
  render::Series runs, means, ci;
  runs.label = "runs";
  runs.style = render::SeriesStyle::kScatter;
  runs.marker_px = 3.0f;
  runs.colour = render::Colour{0.6f, 0.6f, 0.6f, 1.0f};
  means.label = "mean";
  means.style = render::SeriesStyle::kScatter;
  means.marker_px = 7.0f;
  ci.label = "95% CI";
  ci.width_px = 2.5f;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (size_t g = 0; g < groups.size(); ++g) {
    const double x = static_cast<double>(g + 1);
    for (double v : groups[g].values.at(metric)) {
      runs.x.push_back(x + 0.15);
      runs.y.push_back(v);
    }
    const auto& s = groups[g].metrics.at(metric);
    if (s.n == 0) continue;
    means.x.push_back(x);
    means.y.push_back(s.mean);
    if (s.ci95_lo) {
      ci.x.insert(ci.x.end(), {x, x, nan});
      ci.y.insert(ci.y.end(), {*s.ci95_lo, *s.ci95_hi, nan});
    }
  }
  plot.x_range = render::Range{0.5, static_cast<double>(groups.size()) + 0.5};
  if (!ci.x.empty()) plot.series.push_back(ci);
  if (!runs.x.empty()) plot.series.push_back(runs);
  if (!means.x.empty()) plot.series.push_back(means);
  return plot;
}

}  // namespace

Status WriteBatchReportFigure(const std::vector<batch::GroupReport>& groups, const std::string& path) {
  render::Figure fig;
  fig.title = "hexsim batch report: mean and 95% CI per group";
  fig.rows = 2;
  fig.cols = 2;
  fig.panels.emplace_back(MetricPlot(groups, "cross_track_rms_m", "cross-track error RMS [m]"));
  fig.panels.emplace_back(MetricPlot(groups, "yaw_error_rms_deg", "yaw error RMS [deg]"));
  fig.panels.emplace_back(MetricPlot(groups, "energy_Wh", "energy [Wh]"));
  fig.panels.emplace_back(MetricPlot(groups, "current_mean_A", "mean battery current [A]"));
  auto image = render::Render(fig, 1400, 1000);
  if (!image.ok()) return image.status();
  return render::WritePng(*image, path);
}

std::string ReportTable(const std::vector<batch::GroupReport>& groups) {
  std::string out;
  for (const auto& g : groups) {
    std::string status;
    for (const auto& [s, n] : g.status_counts) status += fmt::format("{}{} {}", status.empty() ? "" : ", ", n, s);
    out += fmt::format("{}  ({} runs: {}; figures over the {} that finished)\n", g.label, g.runs, status, g.finished);
    for (const auto& u : g.unfinished) {
      out += fmt::format("  not averaged: seed {} ({}): {}{}{}\n", u.seed, u.run_id, u.status, u.reason.empty() ? "" : ": ",
                         u.reason);
    }
    out += fmt::format("  {:<20} {:>4} {:>12} {:>12} {:>27}\n", "metric", "n", "mean", "std", "95% CI of mean (*: 0 clip)");
    for (const auto& m : batch::MetricColumns()) {
      const batch::MetricStats& s = g.metrics.at(m.column);
      if (s.n == 0) {
        out += fmt::format("  {:<20} {:>4} {:>12}\n", m.column, 0, "-");
        continue;
      }
      out += fmt::format("  {:<20} {:>4} {:>12.4g} {:>12} {:>27}\n", m.column, s.n, s.mean,
                         s.std ? fmt::format("{:.4g}", *s.std) : "-",
                         s.ci95_lo ? fmt::format("[{:.4g}{}, {:.4g}]", *s.ci95_lo, s.ci95_clipped ? "*" : "",
                                                 *s.ci95_hi)
                                   : "-");
    }
  }
  return out;
}

std::string NumberedReportTable(const std::vector<batch::GroupReport>& groups) {
  const std::string table = ReportTable(groups);
  // Number the groups as the figure does.
  std::string numbered;
  size_t g = 0;
  size_t pos = 0;
  while (pos < table.size()) {
    const size_t eol = table.find('\n', pos);
    const std::string line = table.substr(pos, eol == std::string::npos ? std::string::npos : eol - pos + 1);
    numbered += (line.rfind("  ", 0) == 0 ? "" : fmt::format("[{}] ", ++g)) + line;
    if (eol == std::string::npos) break;
    pos = eol + 1;
  }
  return numbered;
}

}  // namespace hexsim::reports
