#include "gap_figures.h"

#include <fmt/format.h>

#include "hexsim/render/figures.h"

namespace hexsim::reports {
namespace {

constexpr const char* kPhaseColours[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728",
                                         "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"};
constexpr const char* kPhases[] = {"ground", "takeoff", "hover", "climb", "cruise", "descent", "landing", "excluded"};
constexpr int kPhaseCount = 8;
constexpr const char* kAxes[3] = {"x", "y", "z"};

render::Series SeriesOf(std::string label, std::vector<double> x, std::vector<double> y) {
  render::Series s;
  s.label = std::move(label);
  s.x = std::move(x);
  s.y = std::move(y);
  return s;
}

std::vector<double> Scaled(const std::vector<Eigen::Vector3d>& v, double scale, int axis) {
  std::vector<double> out;
  out.reserve(v.size());
  for (const auto& x : v) out.push_back(scale * (axis < 0 ? x.norm() : x[axis]));
  return out;
}

GapFigure TimeFigure(const gap::ChannelResult& c, const std::vector<gap::PhaseSpan>& phases, double scale) {
  GapFigure f{"gap_" + c.channel + "_time.png", {}, true};
  render::Plot2D& p = f.plot;
  p.title = c.channel + ": |residual| against time";
  p.x_label = "t (s)";
  p.y_label = "|residual| (" + GapShownUnit(c) + ")";
  p.series.push_back(SeriesOf("before", c.t_s, Scaled(c.residual_before, scale, -1)));
  p.series.push_back(SeriesOf("after", c.t_s, Scaled(c.residual_after, scale, -1)));
  for (const auto& ph : phases) {
    for (int i = 0; i < kPhaseCount; ++i) {
      if (ph.phase == kPhases[i] && ph.t1_s > ph.t0_s) {
        p.spans.push_back({ph.t0_s, ph.t1_s, "", render::Hex(kPhaseColours[i], 0.12f)});
      }
    }
  }
  return f;
}

GapFigure AxesFigure(const gap::ChannelResult& c, double scale) {
  GapFigure f{"gap_" + c.channel + "_axes.png", {}, false};
  render::Plot2D& q = f.plot;
  q.title = c.channel + ": residual per axis, before (solid) and after (dashed) the chosen effect";
  q.x_label = "t (s)";
  q.y_label = GapShownUnit(c);
  for (int a = 0; a < 3; ++a) {
    render::Series sb = SeriesOf(std::string(kAxes[a]) + " before", c.t_s, Scaled(c.residual_before, scale, a));
    render::Series sa = SeriesOf(std::string(kAxes[a]) + " after", c.t_s, Scaled(c.residual_after, scale, a));
    sb.colour = render::PaletteColour(a);
    sa.colour = render::PaletteColour(a);
    sa.dashed = true;
    q.series.push_back(std::move(sb));
    q.series.push_back(std::move(sa));
  }
  return f;
}

GapFigure RegressorFigure(const gap::ChannelResult& c, double scale) {
  GapFigure f{"gap_" + c.channel + "_regressor.png", {}, false};
  render::Plot2D& s = f.plot;
  s.title = c.channel + ": residual against " + c.chosen_regressor_name;
  s.x_label = c.chosen_regressor_name;
  s.y_label = GapShownUnit(c);
  for (int a = 0; a < 3; ++a) {
    render::Series se = SeriesOf(kAxes[a], c.chosen_regressor, Scaled(c.residual_before, scale, a));
    se.style = render::SeriesStyle::kScatter;
    se.marker_px = 2.0f;
    s.series.push_back(std::move(se));
  }
  return f;
}

bool IsCompass(const gap::ChannelResult& c) { return c.unit == "uT"; }

}  // namespace

double GapShownScale(const gap::ChannelResult& c) { return IsCompass(c) ? gap::kMilliGaussPerMicroTesla : 1.0; }
std::string GapShownUnit(const gap::ChannelResult& c) { return IsCompass(c) ? "mG" : c.unit; }

std::vector<GapFigure> GapChannelFigures(const gap::ChannelResult& c, const std::vector<gap::PhaseSpan>& phases) {
  const double scale = GapShownScale(c);
  std::vector<GapFigure> out{TimeFigure(c, phases, scale), AxesFigure(c, scale)};
  if (!c.chosen_regressor.empty() && c.chosen_regressor.size() == c.residual_before.size()) {
    out.push_back(RegressorFigure(c, scale));
  }
  return out;
}

std::string PhaseLegendHtml() {
  std::string h;
  for (int i = 0; i < kPhaseCount; ++i) h += fmt::format("<span style=\"color:{}\">{}</span> ", kPhaseColours[i], kPhases[i]);
  return h;
}

}  // namespace hexsim::reports
