#include "hexsim/reports/response_report.h"

#include <cmath>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "hexsim/render/image.h"
#include "hexsim/render/plot.h"

namespace hexsim::reports {

namespace {

constexpr int kPlotWidth = 1000;
constexpr int kPlotHeight = 560;

std::string Csv(const sim::TimeSeries& s, const std::string& ref, const std::string& out) {
  std::string text = "t_s," + ref + "," + out + "\n";
  for (size_t i = 0; i < s.t_s.size(); ++i) text += fmt::format("{},{},{}\n", s.t_s[i], s.reference[i], s.output[i]);
  return text;
}

Status WritePlot(const render::Plot2D& plot, const std::string& path) {
  auto image = render::Render(plot, kPlotWidth, kPlotHeight);
  if (!image.ok()) return image.status();
  return render::WritePng(*image, path);
}

render::Series Named(const std::string& label) {
  render::Series s;
  s.label = label;
  return s;
}

render::RefLine Ref(render::RefLine::Axis axis, double value, const std::string& label) {
  render::RefLine r;
  r.axis = axis;
  r.value = value;
  r.label = label;
  return r;
}

nlohmann::json Nullable(double v, bool valid) { return valid ? nlohmann::json(v) : nlohmann::json(nullptr); }

}  // namespace

Result<std::string> WriteStepReport(const sim::RunSetup& setup, const experiments::StepRequest& request,
                                    const experiments::StepRun& run, const OutputDirectory& out) {
  const sim::StepTestResult& res = run.result;
  const sim::StepMetrics& m = res.metrics;
  const std::string unit = sim::AxisUnit(run.axis);
  nlohmann::json j = {{"schema", "hexsim.step/1"},
                      {"axis", request.axis},
                      {"unit", unit},
                      {"what", "step on the " + request.axis + " setpoint at hover; output is the true " + request.axis},
                      {"vehicle", setup.vehicle_name},
                      {"estimator", setup.options.estimator},
                      {"seed", setup.options.seed},
                      {"size", request.size},
                      {"t_step_s", res.t_step_s},
                      {"initial", res.initial},
                      {"final_value", m.final_value},
                      {"rise_time_s", Nullable(m.rise_time_s, m.rise_time_s >= 0)},
                      {"overshoot_percent", 100.0 * m.overshoot_fraction},
                      {"peak_time_s", m.peak_time_s},
                      {"settling_time_s", Nullable(m.settling_time_s, m.settling_time_s >= 0)},
                      {"settling_band_percent", 2.0},
                      {"steady_state_error", m.steady_state_error}};
  const std::string text = fmt::format(
      "step {} {:+g} {} ({}, estimator {}):\n  rise time (10-90 %)  {}\n  overshoot            {:.1f} %\n"
      "  settling time (2 %)  {}\n  steady-state error   {:.4g} {}\n",
      request.axis, request.size, unit, setup.vehicle_name, setup.options.estimator,
      m.rise_time_s >= 0 ? fmt::format("{:.3f} s", m.rise_time_s) : "not reached", 100.0 * m.overshoot_fraction,
      m.settling_time_s >= 0 ? fmt::format("{:.3f} s", m.settling_time_s) : "not settled", m.steady_state_error, unit);
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("step.json"), j.dump(2) + "\n"));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("step.txt"), text));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("step.csv"), Csv(res.series, "reference", request.axis)));
  render::Plot2D plot;
  plot.title = fmt::format("{} step {:+g} {}", request.axis, request.size, unit);
  plot.x_label = "time after step (s)";
  plot.y_label = request.axis + " (" + unit + ")";
  render::Series target(Named("setpoint")), y(Named("response"));
  for (size_t i = 0; i < res.series.t_s.size(); ++i) {
    const double t = res.series.t_s[i] - res.t_step_s;
    if (t < -1.0) continue;
    target.x.push_back(t);
    target.y.push_back(res.initial + res.series.reference[i]);
    y.x.push_back(t);
    y.y.push_back(res.series.output[i]);
  }
  target.dashed = true;
  plot.series = {target, y};
  if (m.settling_time_s >= 0) plot.ref_lines.push_back(Ref(render::RefLine::Axis::kVertical, m.settling_time_s, "settled"));
  HEXSIM_RETURN_IF_ERROR(WritePlot(plot, out.File("step.png")));
  return text;
}

Result<std::string> WriteFreqReport(const sim::RunSetup& setup, const experiments::FreqRequest& request,
                                    const experiments::FreqRun& run, const sim::HoverOptions& hover,
                                    const OutputDirectory& out) {
  const sim::FreqTestOptions& o = run.options;
  const sim::LoopMetrics& m = run.result.metrics;
  const sim::FrequencyResponse& fr = run.result.response;
  nlohmann::json pts = nlohmann::json::array();
  std::string csv = "f_hz,gain_db,phase_deg,coherence\n";
  for (size_t i = 0; i < fr.f_hz.size(); ++i) {
    pts.push_back({{"f_hz", fr.f_hz[i]}, {"gain_db", fr.GainDb(i)}, {"phase_deg", fr.PhaseDeg(i)},
                   {"coherence", fr.coherence[i]}});
    csv += fmt::format("{},{},{},{}\n", fr.f_hz[i], fr.GainDb(i), fr.PhaseDeg(i), fr.coherence[i]);
  }
  const std::string what =
      "closed-loop T(f) from the " + request.axis + " setpoint to the true " + request.axis +
      " (multisine added to the setpoint at hover; H1 = S_ry/S_rr, Welch-averaged over whole periods). "
      "Margins are of the loop L = T/(1 - T) closed around that setpoint (unity feedback, no prefilter: "
      "exact for the attitude P loop and the position/velocity loops, whose setpoints enter only "
      "through the error).";
  const bool gm_finite = std::isfinite(m.gain_margin_db);
  nlohmann::json j = {{"schema", "hexsim.freqresp/1"},
                      {"axis", request.axis},
                      {"unit", sim::AxisUnit(run.axis)},
                      {"what", what},
                      {"vehicle", setup.vehicle_name},
                      {"estimator", setup.options.estimator},
                      {"seed", setup.options.seed},
                      {"excitation", {{"kind", "multisine"}, {"f_lo_hz", o.f_lo_hz}, {"f_hi_hz", o.f_hi_hz},
                                      {"amplitude", o.amplitude}, {"period_s", o.period_samples / hover.sample_hz},
                                      {"periods", o.periods}, {"lines", fr.f_hz.size()}}},
                      {"bandwidth_hz", Nullable(m.bandwidth_hz, m.bandwidth_hz > 0)},
                      {"low_frequency_gain_db", m.low_frequency_gain_db},
                      {"peak_gain_db", m.peak_gain_db},
                      {"gain_crossover_hz", Nullable(m.gain_crossover_hz, m.gain_crossover_hz > 0)},
                      {"phase_margin_deg", Nullable(m.phase_margin_deg, m.gain_crossover_hz > 0)},
                      {"phase_crossover_hz", Nullable(m.phase_crossover_hz, m.phase_crossover_hz > 0)},
                      {"gain_margin_db", Nullable(m.gain_margin_db, gm_finite)},
                      {"min_coherence", m.min_coherence},
                      {"coherence_threshold", o.min_coherence},
                      {"points", pts}};
  auto opt = [](double v, const char* fmt_str, bool ok) { return ok ? fmt::format(fmt::runtime(fmt_str), v) : std::string("n/a"); };
  const std::string text = fmt::format(
      "freqresp {} ({}, estimator {}): closed loop setpoint -> true {}\n  bandwidth (-3 dB)  {}\n"
      "  peak |T|           {:.2f} dB\n  phase margin       {} at {}\n  gain margin        {} at {}\n"
      "  min coherence      {:.3f} ({} lines {:.2f}-{:.2f} Hz)\n",
      request.axis, setup.vehicle_name, setup.options.estimator, request.axis, opt(m.bandwidth_hz, "{:.3f} Hz", m.bandwidth_hz > 0),
      m.peak_gain_db, opt(m.phase_margin_deg, "{:.1f} deg", m.gain_crossover_hz > 0),
      opt(m.gain_crossover_hz, "{:.3f} Hz", m.gain_crossover_hz > 0), opt(m.gain_margin_db, "{:.1f} dB", gm_finite),
      opt(m.phase_crossover_hz, "{:.3f} Hz", m.phase_crossover_hz > 0), m.min_coherence, fr.f_hz.size(), fr.f_hz.front(),
      fr.f_hz.back());
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("freqresp.json"), j.dump(2) + "\n"));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("freqresp.txt"), text));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("freqresp.csv"), csv));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("excitation.csv"), Csv(run.result.series, "reference", request.axis)));
  render::Figure fig;
  fig.title = "Bode: " + request.axis + " setpoint -> " + request.axis + " (" + setup.vehicle_name + ")";
  fig.rows = 3;
  render::Plot2D gain, phase, coh;
  gain.y_label = "gain (dB)";
  phase.y_label = "phase (deg)";
  coh.y_label = "coherence";
  coh.x_label = "log10 frequency (Hz)";
  render::Series g(Named("|T|")), p(Named("arg T")), c(Named("coherence"));
  for (size_t i = 0; i < fr.f_hz.size(); ++i) {
    const double lf = std::log10(fr.f_hz[i]);
    g.x.push_back(lf);
    g.y.push_back(fr.GainDb(i));
    p.x.push_back(lf);
    p.y.push_back(fr.PhaseDeg(i));
    c.x.push_back(lf);
    c.y.push_back(fr.coherence[i]);
  }
  g.style = p.style = c.style = render::SeriesStyle::kLineMarkers;
  gain.series = {g};
  gain.ref_lines.push_back(Ref(render::RefLine::Axis::kHorizontal, -3.0, "-3 dB"));
  if (m.bandwidth_hz > 0) gain.ref_lines.push_back(Ref(render::RefLine::Axis::kVertical, std::log10(m.bandwidth_hz), "bandwidth"));
  phase.series = {p};
  coh.series = {c};
  coh.y_range = render::Range{0.0, 1.05};
  coh.ref_lines.push_back(Ref(render::RefLine::Axis::kHorizontal, o.min_coherence, "threshold"));
  fig.panels = {gain, phase, coh};
  auto image = render::Render(fig, kPlotWidth, 900);
  if (!image.ok()) return image.status();
  HEXSIM_RETURN_IF_ERROR(render::WritePng(*image, out.File("bode.png")));
  return text;
}

Result<std::string> WriteDisturbReport(const sim::RunSetup& setup, const sim::DisturbanceSpec& spec,
                                       const sim::DisturbTestResult& result, const OutputDirectory& out) {
  const std::string kind = experiments::DisturbanceKind(spec);
  nlohmann::json j = {{"schema", "hexsim.disturb/1"},
                      {"kind", kind},
                      {"vehicle", setup.vehicle_name},
                      {"estimator", setup.options.estimator},
                      {"seed", setup.options.seed},
                      {"gust_N_mps", {spec.gust_N_mps.x(), spec.gust_N_mps.y(), spec.gust_N_mps.z()}},
                      {"gust_duration_s", spec.gust_duration_s},
                      {"payload_release_kg", spec.payload_release_kg},
                      {"t_onset_s", result.t_onset_s},
                      {"peak_deviation_m", result.peak_deviation_m},
                      {"peak_time_s", result.peak_time_s},
                      {"recovery_band_m", spec.recovery_band_m},
                      {"recovery_time_s", Nullable(result.recovery_time_s, result.recovery_time_s >= 0)},
                      {"peak_tilt_deg", result.peak_tilt_deg}};
  const std::string text = fmt::format(
      "disturb {} at hover ({}, estimator {}):\n  peak deviation  {:.3f} m at {:.2f} s after onset\n"
      "  recovery        {} (back within {:.2f} m)\n  peak tilt       {:.1f} deg\n",
      kind, setup.vehicle_name, setup.options.estimator, result.peak_deviation_m, result.peak_time_s,
      result.recovery_time_s >= 0 ? fmt::format("{:.2f} s", result.recovery_time_s) : "not recovered", spec.recovery_band_m,
      result.peak_tilt_deg);
  std::string csv = "t_s,dev_N_m,dev_E_m,dev_D_m,deviation_m\n";
  for (size_t i = 0; i < result.series.t_s.size(); ++i) {
    csv += fmt::format("{},{},{},{},{}\n", result.series.t_s[i], result.dev_N_m[i], result.dev_E_m[i], result.dev_D_m[i],
                       result.series.output[i]);
  }
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("disturb.json"), j.dump(2) + "\n"));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("disturb.txt"), text));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("disturb.csv"), csv));
  render::Plot2D plot;
  plot.title = "Deviation from the hover point: " + kind;
  plot.x_label = "time after onset (s)";
  plot.y_label = "deviation (m)";
  render::Series sn(Named("N")), se(Named("E")), sd(Named("D")), sa(Named("|dev|"));
  for (size_t i = 0; i < result.series.t_s.size(); ++i) {
    const double t = result.series.t_s[i] - result.t_onset_s;
    if (t < -1.0) continue;
    sn.x.push_back(t), sn.y.push_back(result.dev_N_m[i]);
    se.x.push_back(t), se.y.push_back(result.dev_E_m[i]);
    sd.x.push_back(t), sd.y.push_back(result.dev_D_m[i]);
    sa.x.push_back(t), sa.y.push_back(result.series.output[i]);
  }
  sa.width_px = 2.5f;
  plot.series = {sn, se, sd, sa};
  if (result.recovery_time_s >= 0) plot.ref_lines.push_back(Ref(render::RefLine::Axis::kVertical, result.recovery_time_s, "recovered"));
  plot.ref_lines.push_back(Ref(render::RefLine::Axis::kHorizontal, spec.recovery_band_m, "band"));
  HEXSIM_RETURN_IF_ERROR(WritePlot(plot, out.File("disturb.png")));
  return text;
}

}  // namespace hexsim::reports
