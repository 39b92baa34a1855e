#include "hexsim/reports/gap_report.h"

#include <cmath>

#include <fmt/format.h>

#include "hexsim/common/atomic_file.h"
#include "hexsim/render/figures.h"
#include "hexsim/render/html.h"
#include "hexsim/render/plot.h"
#include "gap_figures.h"

namespace hexsim::reports {

using gap::GapReport;
namespace {

std::string Escape(const std::string& s) { return render::HtmlEscape(s); }

Status Png(const render::Plot2D& p, const std::string& path) {
  auto img = render::Render(p, render::kFigureWidth_px, render::kFigureHeight_px);
  if (!img.ok()) return img.status();
  auto png = render::EncodePng(*img);
  if (!png.ok()) return png.status();
  return WriteFileAtomic(path, *png);
}

double Shown(const gap::ChannelResult& c, double v) { return GapShownScale(c) * v; }

std::string LagRow(const char* what, const gap::LagReport& l) {
  if (!l.present) return "";
  return fmt::format("<tr><td>{}</td><td>{:.0f} ms [{:.0f}, {:.0f}]</td><td>{}</td><td>{}</td></tr>", what, 1000 * l.value_s,
                     1000 * l.ci95_s.lo, 1000 * l.ci95_s.hi, Escape(l.against),
                     !l.resolved ? "reaches the scan's edge: not resolved"
                                 : (l.plausible ? "resolved" : "outside its physical range: model mismatch"));
}

std::string TimingHtml(const gap::Timing& t) {
  if (!t.latency.present && !t.current_staleness.present && !t.current_field_lag.present) return "";
  std::string h = "<h3>Timing</h3><table><tr><th>lag</th><th>value [95 % CI]</th><th>measured against</th><th>status</th></tr>";
  h += LagRow("compass latency", t.latency) + LagRow("logged current's staleness", t.current_staleness) +
       LagRow("current-driven field's lag (current_lag)", t.current_field_lag) + "</table>";
  if (t.latency.present && std::isfinite(t.latency.explained_share)) {
    h += fmt::format("<p>Aligning the compass by its latency removes {:.0f} % of the held-out residual above the noise floor.</p>",
                     100 * t.latency.explained_share);
  }
  return h;
}

std::string NuisanceHtml(const gap::ChannelResult& c) {
  const gap::Nuisance& n = c.nuisance;
  if (!n.present) return "";
  constexpr double kMg = gap::kMilliGaussPerMicroTesla;
  std::string h = "<h3>Nuisance baseline</h3><p>Fitted under every candidate; its terms are findings only when outside their normal ranges.</p><table>";
  h += fmt::format("<tr><td>residual offset (x, y, z)</td><td>({:.1f}, {:.1f}, {:.1f}) mG; |offset| [{:.1f}, {:.1f}] mG</td></tr>",
                   kMg * n.offset_uT.x(), kMg * n.offset_uT.y(), kMg * n.offset_uT.z(), kMg * n.offset_ci95_uT.lo,
                   kMg * n.offset_ci95_uT.hi);
  h += fmt::format("<tr><td>fitted field against the field model</td><td>{}</td></tr>", gap::FieldScaleText(n));
  h += fmt::format("<tr><td>fitted field (N, E, D)</td><td>({:.0f}, {:.0f}, {:.0f}) mG against ({:.0f}, {:.0f}, {:.0f}) mG</td></tr>",
                   kMg * n.field_vector_N_uT.x(), kMg * n.field_vector_N_uT.y(), kMg * n.field_vector_N_uT.z(),
                   kMg * n.field_prior_N_uT.x(), kMg * n.field_prior_N_uT.y(), kMg * n.field_prior_N_uT.z());
  h += fmt::format("<tr><td>field direction error</td><td>{:.1f} mG</td></tr>", kMg * n.field_direction_error_uT);
  if (std::isfinite(n.current_split_exponent)) {
    h += fmt::format("<tr><td>motor current split</td><td>battery current shared as output<sup>{:.2f}</sup></td></tr>",
                     n.current_split_exponent);
  }
  h += fmt::format("<tr><td>autopilot compensation undone</td><td>{}</td></tr></table>", n.undone_compensation ? "yes" : "no");
  return h;
}

std::string EffectsHtml(const gap::ChannelResult& c) {
  if (c.effects.empty()) return "";
  std::string h = "<h3>Effects</h3><p>The material effects, largest first; each share is of the held-out structure above "
                  "the noise floor, the effect alone.</p><table><tr><th>effect</th><th>magnitude [95 % CI]</th>"
                  "<th>autopilot's unit</th><th>explained share</th><th>from</th></tr>";
  for (const gap::EffectShare& e : c.effects) {
    const std::string ap = e.autopilot_unit.empty()
                               ? std::string("&mdash;")
                               : fmt::format("{:.4g} [{:.4g}, {:.4g}] {}", e.autopilot_factor * e.magnitude,
                                             e.autopilot_factor * e.ci95.lo, e.autopilot_factor * e.ci95.hi,
                                             Escape(e.autopilot_unit));
    // A nuisance term beside fitted effects removes nothing over the baseline that absorbed it.
    // A negative held-out share (material by the heading it turns) is none of the structure.
    const std::string share = e.source == "nuisance"      ? std::string("absorbed by the baseline")
                              : e.explained_share < 0 ? fmt::format("none (held out {:.0f} % worse)", -100 * e.explained_share)
                                                      : fmt::format("{:.0f} %", 100 * e.explained_share);
    h += fmt::format("<tr><td>{}</td><td>{:.4g} [{:.4g}, {:.4g}] {}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                     Escape(e.effect), e.magnitude, e.ci95.lo, e.ci95.hi, Escape(e.unit), ap, share, Escape(e.source));
  }
  return h + "</table>";
}

// Every fitted candidate, for reference, folded: the selection is the effects table above (the
// bootstrap's information-criterion winner is not the selection rule, so no probability is shown).
std::string CandidatesHtml(const gap::ChannelResult& c) {
  std::string h = "<details><summary>Every fitted candidate</summary><table><tr><th>effect</th><th>selected</th>"
                  "<th>explained share</th><th>p (family-corrected)</th><th>magnitude [95 % CI]</th><th>physical range</th>"
                  "<th>plausible</th></tr>";
  for (const auto& k : c.candidates) {
    h += fmt::format("<tr><td>{}{}</td><td>{}</td><td>{:.0f} %</td><td>{:.2g}</td><td>{:.4g} [{:.4g}, {:.4g}] {}</td><td>{}</td>"
                     "<td>{}</td></tr>",
                     Escape(k.effect), k.nuisance_term ? " (nuisance term)" : "", k.selected ? "yes" : "",
                     100 * k.explained_share, k.p_value, k.magnitude, k.magnitude_ci95[0], k.magnitude_ci95[1],
                     Escape(k.magnitude_unit), Escape(k.physical_range), k.plausible ? "yes" : "<b>no: model mismatch</b>");
  }
  return h + "</table></details>";
}

std::string LeftHtml(const gap::ResidualLeft& l) {
  if (!l.present) return "";
  return fmt::format("<h3>What is left</h3><p>{:.0f} % of the held-out structure above the noise floor is left after the "
                     "reported effects; its dominant frequency is {:.3g} Hz, a straight line in time holds {:.0f} % of it, "
                     "{} isolated spikes, concentrated in {}.</p>",
                     100 * l.share, l.dominant_freq_Hz, 100 * l.trend, l.spikes,
                     Escape(l.concentrated.empty() ? "no phase or regime" : l.concentrated));
}

// The channel's figures as PNGs beside gap.html, each in a paragraph (the time figure with its
// phase shading's legend).
Status ChannelFigures(const gap::ChannelResult& c, const std::vector<gap::PhaseSpan>& phases, const std::string& dir,
                      std::string* html) {
  for (const GapFigure& f : GapChannelFigures(c, phases)) {
    HEXSIM_RETURN_IF_ERROR(Png(f.plot, fmt::format("{}/{}", dir, f.file)));
    *html += "<p><img src=\"" + f.file + "\">" + (f.phase_legend ? "<br>Shading: " + PhaseLegendHtml() : "") + "</p>";
  }
  return Status::Ok();
}

}  // namespace

Status WriteGapHtml(const GapReport& r, const std::string& dir) {
  std::string html = "<!doctype html><html><head><meta charset=\"utf-8\"><title>hexsim gap diagnosis</title>"
                     "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
                     "<style>body{font-family:sans-serif;max-width:1150px;margin:auto;padding:0 8px}"
                     "table{border-collapse:collapse;max-width:100%;display:block;overflow-x:auto}"
                     "td,th{border:1px solid #ccc;padding:3px 6px}img{max-width:100%;height:auto}"
                     "pre{white-space:pre-wrap;overflow-wrap:anywhere}</style></head><body>";
  html += "<h1>Sim-to-real gap diagnosis</h1><p>Log: " + Escape(r.log_name) + "<br>Attitude taken as truth: " +
          Escape(r.attitude_source) + "<br>Field model: " + Escape(r.field_model) + "</p>";
  html += "<pre>" + Escape(Summary(r)) + "</pre>";
  if (!r.windows.empty()) {
    html += "<h2>Windows</h2><p>" + Escape(r.windows_source) + "</p><table><tr><th>kind</th><th>from (s)</th><th>to (s)</th><th>why</th></tr>";
    for (const auto& w : r.windows) {
      html += fmt::format("<tr><td>{}</td><td>{:.1f}</td><td>{:.1f}</td><td>{}</td></tr>", Escape(w.kind), w.start_s, w.end_s,
                          Escape(w.why));
    }
    html += "</table>";
  }
  for (const auto& c : r.channels) {
    html += "<h2>" + Escape(c.channel) + "</h2>";
    html += fmt::format("<p>verdict <b>{}</b>{}; residual RMS {:.3g} {}, noise floor {:.2g} {} RMS, p = {:.3g}, "
                        "held-out shrink {:.0f} %{}</p>",
                        Escape(c.verdict), c.partial ? " (partial)" : "", Shown(c, c.rms_before), GapShownUnit(c),
                        Shown(c, c.noise_rms), GapShownUnit(c), c.p_value, 100 * c.heldout_shrink,
                        c.reference_contaminated ? " &mdash; <b>reference-contaminated</b>" : "");
    if (!c.headline.empty()) html += "<p><b>" + Escape(c.headline) + "</b></p>";
    if (!c.explanation.empty()) html += "<p>" + Escape(c.explanation) + "</p>";
    if (!c.findings.empty()) {
      html += "<ul>";
      for (const auto& f : c.findings) html += "<li>" + Escape(f) + "</li>";
      html += "</ul>";
    }
    html += TimingHtml(c.timing) + NuisanceHtml(c) + LeftHtml(c.residual_left);
    html += EffectsHtml(c) + CandidatesHtml(c);
    HEXSIM_RETURN_IF_ERROR(ChannelFigures(c, r.phases, dir, &html));
  }
  if (!r.not_diagnosed.empty()) {
    html += "<h2>Not diagnosed</h2><ul>";
    for (const auto& [ch, why] : r.not_diagnosed) html += "<li>" + Escape(ch) + ": " + Escape(why) + "</li>";
    html += "</ul>";
  }
  html += "<p>Effects not built: ";
  for (const auto& e : r.effects_not_built) html += e + " ";
  html += "</p></body></html>\n";
  return WriteFileAtomic(dir + "/gap.html", html);
}

}  // namespace hexsim::reports
