// identify.json (hexsim.identify/1), identify.html and the text summary.
#include <cmath>

#include <fmt/format.h>

#include "hexsim/common/atomic_file.h"
#include "hexsim/identify/identify.h"
#include "hexsim/render/html.h"
#include "hexsim/render/image.h"
#include "hexsim/render/plot.h"

namespace hexsim::identify {
namespace {

nlohmann::json Num(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

render::Series MakeSeries(std::string label, std::vector<double> x, std::vector<double> y, size_t colour) {
  render::Series s;
  s.label = std::move(label);
  s.x = std::move(x);
  s.y = std::move(y);
  s.colour = render::PaletteColour(colour);
  return s;
}

Status Png(const render::Plot2D& p, const std::string& path) {
  constexpr int kWidth_px = 1100, kHeight_px = 420;
  auto img = render::Render(p, kWidth_px, kHeight_px);
  if (!img.ok()) return img.status();
  auto png = render::EncodePng(*img);
  if (!png.ok()) return png.status();
  return WriteFileAtomic(path, *png);
}

double Median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

nlohmann::json ToJson(const IdentifyResult& r) {
  nlohmann::json j;
  j["schema"] = "hexsim.identify/1";
  j["frame"] = r.frame;
  j["frame_source"] = r.frame_source;
  j["motors"] = r.motors;
  j["base"] = r.base_name;
  j["spins"] = r.spins;
  j["data_source"] = r.data_source;
  j["v_ref_V"] = r.v_ref_V;
  j["thrust_expo"] = {{"value", Num(r.thrust_expo)}, {"source", r.thrust_expo_source}};
  nlohmann::json params = nlohmann::json::object();
  for (const auto& k : r.param_order) {
    const Param& p = r.params.at(k);
    params[k] = {{"value", Num(p.value)},
                 {"ci95", {Num(p.ci95[0]), Num(p.ci95[1])}},
                 {"unit", p.unit},
                 {"source", p.source},
                 {"physical_range", {Num(p.range[0]), Num(p.range[1])}},
                 {"physical_range_reason", p.range_reason},
                 {"plausible", p.plausible()},
                 {"applied", p.applied},
                 {"note", p.note}};
  }
  j["params"] = params;
  nlohmann::json held = nlohmann::json::object();
  for (const auto& h : r.heldout) {
    held[h.output] = {{"unit", h.unit},
                      {"rms_measured", h.rms_measured},
                      {"rms_residual", h.rms_residual},
                      {"r2", h.r2},
                      {"samples", h.samples},
                      {"how", "fitted on the even time blocks, scored on the odd ones"}};
  }
  held["dynamics_specific_force"] = {
      {"unit", "m/s^2"},
      {"rms_base_vehicle", r.dynamics_rms_base},
      {"rms_identified_vehicle", r.dynamics_rms_identified},
      {"drop", r.dynamics_rms_base > 0 ? 1.0 - r.dynamics_rms_identified / r.dynamics_rms_base : 0.0},
      {"how", "3-axis RMS about zero on the odd blocks; thrust from hexsim's steady powertrain at the logged outputs "
              "and voltage, drag from the vehicle; identified vehicle fitted on the even blocks"}};
  j["heldout_fit"] = held;
  nlohmann::json win = nlohmann::json::array();
  for (const auto& w : r.windows) win.push_back({{"start_s", w.start_s}, {"end_s", w.end_s}, {"kind", w.kind}, {"why", w.why}});
  j["windows"] = win;
  j["hover_check"] = {{"steady_hover_samples", r.hover_output.size()},
                      {"median_motor_output", Num(Median(r.hover_output))},
                      {"median_voltage_V", Num(Median(r.hover_voltage_V))}};
  j["notes"] = r.notes;
  return j;
}

std::string Summary(const IdentifyResult& r) {
  std::string s = fmt::format("frame {} ({}), base {}; {}\n", r.frame, r.frame_source, r.base_name, r.data_source);
  for (const auto& k : r.param_order) {
    const Param& p = r.params.at(k);
    s += fmt::format("  {:<32} {:>11.5g}  [{:.5g}, {:.5g}] {:<7} {}{}\n", k, p.value, p.ci95[0], p.ci95[1], p.unit, p.source,
                     p.source == "fitted" && !p.applied ? " (not applied: interval leaves the physical range)" : "");
  }
  for (const auto& h : r.heldout) {
    s += fmt::format("  held-out {:<24} RMS {:.4g} -> residual {:.4g} {} (R² {:.2f}, {} samples)\n", h.output,
                     h.rms_measured, h.rms_residual, h.unit, h.r2, h.samples);
  }
  s += fmt::format("  held-out dynamics residual (3 axes, RMS): base vehicle {:.3g} m/s^2, identified {:.3g} m/s^2\n",
                   r.dynamics_rms_base, r.dynamics_rms_identified);
  if (!r.hover_output.empty()) {
    s += fmt::format("  steady hover in the log: median motor output {:.3f} at {:.2f} V ({} samples)\n",
                     Median(r.hover_output), Median(r.hover_voltage_V), r.hover_output.size());
  }
  for (const auto& note : r.notes) s += "  note: " + note + "\n";
  return s;
}

Status WriteIdentifyHtml(const IdentifyResult& r, const std::string& dir) {
  using render::HtmlEscape;
  std::string html = "<!doctype html><html><head><meta charset=\"utf-8\"><title>hexsim identify</title>"
                     "<style>body{font-family:sans-serif;max-width:1150px;margin:auto}table{border-collapse:collapse}"
                     "td,th{border:1px solid #ccc;padding:3px 6px}img{max-width:100%}</style></head><body>";
  html += "<h1>Vehicle identification</h1><p>Frame " + HtmlEscape(r.frame) + " (" + HtmlEscape(r.frame_source) +
          "), base vehicle " + HtmlEscape(r.base_name) + ".<br>" + HtmlEscape(r.data_source) + ".</p>";
  html += "<table><tr><th>parameter</th><th>value</th><th>95 % interval</th><th>unit</th><th>source</th><th>physical "
          "range</th><th>definition</th></tr>";
  for (const auto& k : r.param_order) {
    const Param& p = r.params.at(k);
    html += fmt::format("<tr><td>{}</td><td>{:.5g}</td><td>[{:.5g}, {:.5g}]</td><td>{}</td><td>{}</td><td title=\"{}\">"
                        "[{:.4g}, {:.4g}]</td><td>{}</td></tr>",
                        k, p.value, p.ci95[0], p.ci95[1], HtmlEscape(p.unit), HtmlEscape(p.source),
                        HtmlEscape(p.range_reason), p.range[0], p.range[1], HtmlEscape(p.note));
  }
  html += "</table><h2>Held-out fit (fitted on even time blocks, scored on odd ones)</h2><table><tr><th>output</th>"
          "<th>RMS measured</th><th>RMS residual</th><th>R²</th><th>samples</th></tr>";
  for (const auto& h : r.heldout) {
    html += fmt::format("<tr><td>{}</td><td>{:.4g} {}</td><td>{:.4g}</td><td>{:.3f}</td><td>{}</td></tr>", h.output,
                        h.rms_measured, HtmlEscape(h.unit), h.rms_residual, h.r2, h.samples);
  }
  html += "</table>";
  for (size_t i = 0; i < r.traces.size(); ++i) {
    const Trace& tr = r.traces[i];
    render::Plot2D p;
    p.title = tr.output + ": measured and predicted on held-out blocks";
    p.x_label = "t (s)";
    p.y_label = tr.unit;
    p.series.push_back(MakeSeries("measured", tr.t_s, tr.measured, 0));
    p.series.push_back(MakeSeries("predicted", tr.t_s, tr.predicted, 1));
    const std::string f = fmt::format("identify_{}.png", i == 0 ? "vertical" : "yaw");
    HEXSIM_RETURN_IF_ERROR(Png(p, fmt::format("{}/{}", dir, f)));
    html += fmt::format("<p><img src=\"{}\"></p>", f);
  }
  if (!r.hover_output.empty()) {
    render::Plot2D p;
    p.title = "Steady hover: mean motor output against bus voltage";
    p.x_label = "bus voltage (V)";
    p.y_label = "mean motor output";
    render::Series s = MakeSeries("steady-hover samples", r.hover_voltage_V, r.hover_output, 0);
    s.style = render::SeriesStyle::kScatter;
    s.marker_px = 2.0f;
    p.series.push_back(s);
    const auto it = r.params.find("hover_output");
    if (it != r.params.end() && std::isfinite(it->second.value)) {
      p.ref_lines.push_back({render::RefLine::Axis::kHorizontal, it->second.value, "identified hover output at V_ref"});
    }
    HEXSIM_RETURN_IF_ERROR(Png(p, dir + "/identify_hover.png"));
    html += "<p><img src=\"identify_hover.png\"></p>";
  }
  html += "<h2>Windows</h2><ul>";
  for (const auto& w : r.windows) {
    html += fmt::format("<li>{:.1f}–{:.1f} s: {} ({})</li>", w.start_s, w.end_s, w.kind, HtmlEscape(w.why));
  }
  html += "</ul></body></html>\n";
  return WriteFileAtomic(dir + "/identify.html", html);
}

}  // namespace hexsim::identify
