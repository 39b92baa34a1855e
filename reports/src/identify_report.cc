// identify.html with its PNG plots (moved from identify/, which no longer depends on render/).
#include "hexsim/reports/identify_report.h"

#include <string>
#include <vector>

#include <fmt/format.h>

#include "hexsim/common/atomic_file.h"
#include "hexsim/render/html.h"
#include "hexsim/render/image.h"
#include "hexsim/render/plot.h"

namespace hexsim::reports {
namespace {

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

// What became of a parameter in the vehicle written, in the words stdout uses.
std::string InTheVehicle(const identify::Param& p) {
  if (p.source == "base") return "kept from the base";
  if (p.source == "model mismatch") return "not applied: outside its physical range (model mismatch), base kept";
  if (!p.applied) return "not applied: " + p.not_applied + ", base kept";
  return "applied";
}

std::string Head() {
  // Fits the viewport: no fixed widths, long text wraps, tables scroll inside themselves if ever wider.
  return "<!doctype html><html><head><meta charset=\"utf-8\"><meta name=\"viewport\" content=\"width=device-width, "
         "initial-scale=1\"><title>hexsim identify</title><style>body{font-family:sans-serif;max-width:1150px;margin:"
         "auto;padding:0 8px;overflow-wrap:anywhere}.wide{overflow-x:auto}table{border-collapse:collapse}td,th{border:"
         "1px solid #ccc;padding:3px 6px;vertical-align:top}th,td.n,td.u{white-space:nowrap}td.n{text-align:right}td.k{overflow-wrap:normal}td.d{min-width:16em}img{max-width:"
         "100%;height:auto}.warn{background:#fde;padding:6px;border:1px solid #c99}</style></head><body>";
}

// A parameter name that may wrap after each underscore (a long name never breaks mid-word).
std::string Breakable(const std::string& name) {
  std::string out;
  for (char ch : name) {
    out += render::HtmlEscape(std::string(1, ch));
    if (ch == '_') out += "<wbr>";
  }
  return out;
}

std::string ParamTable(const identify::IdentifyResult& r) {
  using render::HtmlEscape;
  std::string html = "<div class=\"wide\"><table><tr><th>parameter</th><th>value</th><th>95 % interval</th>"
                     "<th>physical range</th><th>unit</th><th>source</th><th>in the vehicle</th><th>definition</th></tr>";
  for (const auto& k : r.param_order) {
    const identify::Param& p = r.params.at(k);
    html += fmt::format("<tr><td class=\"k\">{}</td><td class=\"n\">{:.5g}</td><td class=\"n\">[{:.5g}, {:.5g}]</td><td "
                        "class=\"n\" title=\"{}\">[{:.4g}, {:.4g}]</td><td class=\"u\">{}</td><td class=\"k\">{}</td><td>{}</td><td class=\"d\">{}</td></tr>",
                        Breakable(k), p.value, p.ci95[0], p.ci95[1], HtmlEscape(p.range_reason), p.range[0], p.range[1],
                        HtmlEscape(p.unit), HtmlEscape(p.source), InTheVehicle(p), HtmlEscape(p.note));
  }
  return html + "</table></div>";
}

std::string HeldOutTable(const identify::IdentifyResult& r) {
  using render::HtmlEscape;
  std::string html = "<h2>Held-out fit (fitted on even time blocks, scored on odd ones)</h2><div class=\"wide\"><table>"
                     "<tr><th>output</th><th>unit</th><th>RMS measured</th><th>RMS residual</th><th>R²</th>"
                     "<th>samples</th></tr>";
  for (const auto& h : r.heldout) {
    html += fmt::format("<tr><td>{}</td><td>{}</td><td class=\"n\">{:.4g}</td><td class=\"n\">{:.4g}</td><td "
                        "class=\"n\">{:.3f}</td><td class=\"n\">{}</td></tr>",
                        h.output, HtmlEscape(h.unit), h.rms_measured, h.rms_residual, h.r2, h.samples);
  }
  if (r.dynamics_not_comparable.empty()) {
    html += fmt::format("<tr><td>dynamics (3 axes, RMS about zero)</td><td>m/s^2</td><td class=\"n\">base vehicle "
                        "{:.3g}</td><td class=\"n\">identified {:.3g}</td><td></td><td></td></tr>",
                        r.dynamics_rms_base, r.dynamics_rms_identified);
  } else {
    html += "<tr><td>dynamics (3 axes, RMS about zero)</td><td>m/s^2</td><td colspan=\"4\">not compared: " +
            render::HtmlEscape(r.dynamics_not_comparable) + "</td></tr>";
  }
  html += "</table></div>";
  return html;
}

}  // namespace

Status WriteIdentifyHtml(const identify::IdentifyResult& r, const std::string& dir) {
  using render::HtmlEscape;
  std::string html = Head();
  html += "<h1>Vehicle identification</h1><p>Frame " + HtmlEscape(r.frame) + " (" + HtmlEscape(r.frame_source) +
          "), base vehicle " + HtmlEscape(r.base_name) + ".<br>" + HtmlEscape(r.data_source) + ".</p>";
  html += r.improves_on_base ? "<p>" + HtmlEscape(identify::ImprovementLine(r)) + ".</p>"
                             : "<p class=\"warn\">" + HtmlEscape(identify::ImprovementLine(r)) +
                                   ": no vehicle file was written.</p>";
  size_t applied = 0;
  for (const auto& [k, p] : r.params) applied += p.applied ? 1 : 0;
  html += fmt::format("<p>{} of {} parameters applied to the vehicle written; the others keep the base's values "
                      "(column \"in the vehicle\").</p>",
                      applied, r.params.size());
  html += ParamTable(r) + HeldOutTable(r);
  for (size_t i = 0; i < r.traces.size(); ++i) {
    const identify::Trace& tr = r.traces[i];
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
  if (!r.notes.empty()) {
    html += "<h2>Notes</h2><ul>";
    for (const auto& n : r.notes) html += "<li>" + HtmlEscape(n) + "</li>";
    html += "</ul>";
  }
  html += "<h2>Windows</h2><ul>";
  for (const auto& w : r.windows) {
    html += fmt::format("<li>{:.1f}–{:.1f} s: {} ({})</li>", w.start_s, w.end_s, w.kind, HtmlEscape(w.why));
  }
  html += "</ul></body></html>\n";
  return WriteFileAtomic(dir + "/identify.html", html);
}

}  // namespace hexsim::reports
