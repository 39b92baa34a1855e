// Response tools for controller development (hover experiments built on sim::Simulation):
//   hexsim step     --axis roll|pitch|yaw|alt|vel_N --size X [--duration S] --out DIR
//   hexsim freqresp --axis ... [--f-lo HZ --f-hi HZ --amplitude A --periods N] --out DIR
//   hexsim disturb  (--gust N,E,D | --payload-release KG) [--gust-duration S] --out DIR
// Common: [--vehicle V] [--world W] [--estimator truth|eskf|complementary] [--seed N]
//         [--set KEY=VALUE ...] [--hover-alt M] [--settle S]
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli_util.h"
#include "commands.h"
#include "hexsim/common/atomic_file.h"
#include "hexsim/render/image.h"
#include "hexsim/render/plot.h"
#include "hexsim/sim/hover_tests.h"
#include "hexsim/sim/run_config.h"

namespace hexsim::app {

namespace {

constexpr int kPlotWidth = 1000;
constexpr int kPlotHeight = 560;

struct CommonArgs {
  sim::RunRequest request;
  double hover_alt_m = 10.0;
  double settle_s = 12.0;
  std::string out;
};

void AddCommon(CLI::App* cmd, CommonArgs* a) {
  a->request.estimator = "truth";  // response of the loop itself; --estimator eskf flies on the estimate
  cmd->add_option("--vehicle", a->request.vehicle, "Vehicle name or YAML path")->capture_default_str();
  cmd->add_option("--world", a->request.world, "Environment name or YAML path")->capture_default_str();
  cmd->add_option("--estimator", a->request.estimator, "truth|eskf|complementary")->capture_default_str();
  cmd->add_option("--seed", a->request.seed, "Random seed")->capture_default_str();
  cmd->add_option("--set", a->request.sets, "Override a parameter, e.g. control.rate.roll.kp=20");
  cmd->add_option("--hover-alt", a->hover_alt_m, "Hover altitude (m)")->capture_default_str();
  cmd->add_option("--settle", a->settle_s, "Take-off and settling time before the test (s)")->capture_default_str();
  cmd->add_option("--out", a->out, "Output directory")->required();
}

Result<sim::RunSetup> Load(const CommonArgs& a, sim::HoverOptions* hover) {
  hover->hover_alt_m = a.hover_alt_m;
  hover->settle_s = a.settle_s;
  return sim::LoadRunSetup(a.request);
}

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

// --- step ----------------------------------------------------------------------------------------

struct StepArgs {
  CommonArgs common;
  std::string axis = "roll";
  double size = 0.0;
  double duration_s = 0.0;  // 0: per axis
};

Status StepCommand(const StepArgs& a) {
  auto axis = sim::ParseResponseAxis(a.axis);
  if (!axis.ok()) return axis.status();
  sim::HoverOptions hover;
  auto setup = Load(a.common, &hover);
  if (!setup.ok()) return setup.status();
  const bool attitude = sim::IsAttitudeAxis(*axis);
  const double after_s = a.duration_s > 0 ? a.duration_s : (attitude ? 4.0 : 15.0);
  OutputDirectory out;
  HEXSIM_RETURN_IF_ERROR(out.Open(a.common.out));
  auto r = sim::RunStepTest(*setup, *axis, a.size, after_s, hover);
  if (!r.ok()) return r.status();
  const sim::StepMetrics& m = r->metrics;
  const std::string unit = sim::AxisUnit(*axis);
  nlohmann::json j = {{"schema", "hexsim.step/1"},
                      {"axis", a.axis},
                      {"unit", unit},
                      {"what", "step on the " + a.axis + " setpoint at hover; output is the true " + a.axis},
                      {"vehicle", setup->vehicle_name},
                      {"estimator", setup->options.estimator},
                      {"seed", setup->options.seed},
                      {"size", a.size},
                      {"t_step_s", r->t_step_s},
                      {"initial", r->initial},
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
      a.axis, a.size, unit, setup->vehicle_name, setup->options.estimator,
      m.rise_time_s >= 0 ? fmt::format("{:.3f} s", m.rise_time_s) : "not reached", 100.0 * m.overshoot_fraction,
      m.settling_time_s >= 0 ? fmt::format("{:.3f} s", m.settling_time_s) : "not settled", m.steady_state_error, unit);
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("step.json"), j.dump(2) + "\n"));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("step.txt"), text));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("step.csv"), Csv(r->series, "reference", a.axis)));
  render::Plot2D plot;
  plot.title = fmt::format("{} step {:+g} {}", a.axis, a.size, unit);
  plot.x_label = "time after step (s)";
  plot.y_label = a.axis + " (" + unit + ")";
  render::Series target(Named("setpoint")), y(Named("response"));
  for (size_t i = 0; i < r->series.t_s.size(); ++i) {
    const double t = r->series.t_s[i] - r->t_step_s;
    if (t < -1.0) continue;
    target.x.push_back(t);
    target.y.push_back(r->initial + r->series.reference[i]);
    y.x.push_back(t);
    y.y.push_back(r->series.output[i]);
  }
  target.dashed = true;
  plot.series = {target, y};
  if (m.settling_time_s >= 0) plot.ref_lines.push_back(Ref(render::RefLine::Axis::kVertical, m.settling_time_s, "settled"));
  HEXSIM_RETURN_IF_ERROR(WritePlot(plot, out.File("step.png")));
  out.Commit();
  std::fputs(text.c_str(), stdout);
  return Status::Ok();
}

// --- freqresp ------------------------------------------------------------------------------------

struct FreqArgs {
  CommonArgs common;
  std::string axis = "roll";
  double f_lo_hz = 0.0, f_hi_hz = 0.0, amplitude = 0.0;  // 0: per axis
  int periods = 4;
  double min_coherence = 0.8;
};

Status FreqCommand(const FreqArgs& a) {
  auto axis = sim::ParseResponseAxis(a.axis);
  if (!axis.ok()) return axis.status();
  sim::HoverOptions hover;
  auto setup = Load(a.common, &hover);
  if (!setup.ok()) return setup.status();
  const bool attitude = sim::IsAttitudeAxis(*axis);
  sim::FreqTestOptions o;
  o.f_lo_hz = a.f_lo_hz > 0 ? a.f_lo_hz : (attitude ? 0.2 : 0.05);
  o.f_hi_hz = a.f_hi_hz > 0 ? a.f_hi_hz : (attitude ? 8.0 : 3.0);
  o.amplitude = a.amplitude > 0 ? a.amplitude : (attitude ? (*axis == sim::ResponseAxis::kYaw ? 8.0 : 4.0) : 0.5);
  o.period_samples = attitude ? 2048 : 4096;  // 10.24 s / 20.48 s at 200 Hz
  o.periods = a.periods;
  o.min_coherence = a.min_coherence;
  OutputDirectory out;
  HEXSIM_RETURN_IF_ERROR(out.Open(a.common.out));
  auto r = sim::RunFrequencyTest(*setup, *axis, o, hover);
  if (!r.ok()) return r.status();
  const sim::LoopMetrics& m = r->metrics;
  const sim::FrequencyResponse& fr = r->response;
  nlohmann::json pts = nlohmann::json::array();
  std::string csv = "f_hz,gain_db,phase_deg,coherence\n";
  for (size_t i = 0; i < fr.f_hz.size(); ++i) {
    pts.push_back({{"f_hz", fr.f_hz[i]}, {"gain_db", fr.GainDb(i)}, {"phase_deg", fr.PhaseDeg(i)},
                   {"coherence", fr.coherence[i]}});
    csv += fmt::format("{},{},{},{}\n", fr.f_hz[i], fr.GainDb(i), fr.PhaseDeg(i), fr.coherence[i]);
  }
  const std::string what =
      "closed-loop T(f) from the " + a.axis + " setpoint to the true " + a.axis +
      " (multisine added to the setpoint at hover; H1 = S_ry/S_rr, Welch-averaged over whole periods). "
      "Margins are of the loop L = T/(1 - T) closed around that setpoint (unity feedback, no prefilter: "
      "exact for the attitude P loop and the position/velocity loops, whose setpoints enter only "
      "through the error).";
  const bool gm_finite = std::isfinite(m.gain_margin_db);
  nlohmann::json j = {{"schema", "hexsim.freqresp/1"},
                      {"axis", a.axis},
                      {"unit", sim::AxisUnit(*axis)},
                      {"what", what},
                      {"vehicle", setup->vehicle_name},
                      {"estimator", setup->options.estimator},
                      {"seed", setup->options.seed},
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
      a.axis, setup->vehicle_name, setup->options.estimator, a.axis, opt(m.bandwidth_hz, "{:.3f} Hz", m.bandwidth_hz > 0),
      m.peak_gain_db, opt(m.phase_margin_deg, "{:.1f} deg", m.gain_crossover_hz > 0),
      opt(m.gain_crossover_hz, "{:.3f} Hz", m.gain_crossover_hz > 0), opt(m.gain_margin_db, "{:.1f} dB", gm_finite),
      opt(m.phase_crossover_hz, "{:.3f} Hz", m.phase_crossover_hz > 0), m.min_coherence, fr.f_hz.size(), fr.f_hz.front(),
      fr.f_hz.back());
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("freqresp.json"), j.dump(2) + "\n"));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("freqresp.txt"), text));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("freqresp.csv"), csv));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("excitation.csv"), Csv(r->series, "reference", a.axis)));
  render::Figure fig;
  fig.title = "Bode: " + a.axis + " setpoint -> " + a.axis + " (" + setup->vehicle_name + ")";
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
  out.Commit();
  std::fputs(text.c_str(), stdout);
  return Status::Ok();
}

// --- disturb -------------------------------------------------------------------------------------

struct DisturbArgs {
  CommonArgs common;
  std::string gust;  // "N,E,D"
  double gust_duration_s = 0.0;
  double payload_release_kg = 0.0;
  double after_s = 15.0;
  double band_m = 0.25;
};

Result<Eigen::Vector3d> ParseVec3(const std::string& text, const std::string& what) {
  Eigen::Vector3d v;
  std::stringstream ss(text);
  std::string item;
  int i = 0;
  while (std::getline(ss, item, ',')) {
    if (i >= 3) return Status::BadInput(what + ": expected N,E,D");
    try {
      size_t used = 0;
      v[i] = std::stod(item, &used);
      if (used != item.size() || !std::isfinite(v[i])) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      return Status::BadInput(fmt::format("{}: '{}' is not a number", what, item));
    }
    ++i;
  }
  if (i != 3) return Status::BadInput(what + ": expected N,E,D");
  return v;
}

Status DisturbCommand(const DisturbArgs& a) {
  sim::DisturbanceSpec spec;
  if (!a.gust.empty()) {
    auto g = ParseVec3(a.gust, "--gust");
    if (!g.ok()) return g.status();
    spec.gust_N_mps = *g;
  }
  spec.gust_duration_s = a.gust_duration_s;
  spec.payload_release_kg = a.payload_release_kg;
  spec.after_s = a.after_s;
  spec.recovery_band_m = a.band_m;
  sim::HoverOptions hover;
  auto setup = Load(a.common, &hover);
  if (!setup.ok()) return setup.status();
  OutputDirectory out;
  HEXSIM_RETURN_IF_ERROR(out.Open(a.common.out));
  auto r = sim::RunDisturbTest(*setup, spec, hover);
  if (!r.ok()) return r.status();
  const std::string kind = spec.payload_release_kg > 0 && !spec.gust_N_mps.isZero()
                               ? "gust+payload_release"
                               : (spec.payload_release_kg > 0 ? "payload_release" : "gust");
  nlohmann::json j = {{"schema", "hexsim.disturb/1"},
                      {"kind", kind},
                      {"vehicle", setup->vehicle_name},
                      {"estimator", setup->options.estimator},
                      {"seed", setup->options.seed},
                      {"gust_N_mps", {spec.gust_N_mps.x(), spec.gust_N_mps.y(), spec.gust_N_mps.z()}},
                      {"gust_duration_s", spec.gust_duration_s},
                      {"payload_release_kg", spec.payload_release_kg},
                      {"t_onset_s", r->t_onset_s},
                      {"peak_deviation_m", r->peak_deviation_m},
                      {"peak_time_s", r->peak_time_s},
                      {"recovery_band_m", spec.recovery_band_m},
                      {"recovery_time_s", Nullable(r->recovery_time_s, r->recovery_time_s >= 0)},
                      {"peak_tilt_deg", r->peak_tilt_deg}};
  const std::string text = fmt::format(
      "disturb {} at hover ({}, estimator {}):\n  peak deviation  {:.3f} m at {:.2f} s after onset\n"
      "  recovery        {} (back within {:.2f} m)\n  peak tilt       {:.1f} deg\n",
      kind, setup->vehicle_name, setup->options.estimator, r->peak_deviation_m, r->peak_time_s,
      r->recovery_time_s >= 0 ? fmt::format("{:.2f} s", r->recovery_time_s) : "not recovered", spec.recovery_band_m,
      r->peak_tilt_deg);
  std::string csv = "t_s,dev_N_m,dev_E_m,dev_D_m,deviation_m\n";
  for (size_t i = 0; i < r->series.t_s.size(); ++i) {
    csv += fmt::format("{},{},{},{},{}\n", r->series.t_s[i], r->dev_N_m[i], r->dev_E_m[i], r->dev_D_m[i],
                       r->series.output[i]);
  }
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("disturb.json"), j.dump(2) + "\n"));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("disturb.txt"), text));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(out.File("disturb.csv"), csv));
  render::Plot2D plot;
  plot.title = "Deviation from the hover point: " + kind;
  plot.x_label = "time after onset (s)";
  plot.y_label = "deviation (m)";
  render::Series sn(Named("N")), se(Named("E")), sd(Named("D")), sa(Named("|dev|"));
  for (size_t i = 0; i < r->series.t_s.size(); ++i) {
    const double t = r->series.t_s[i] - r->t_onset_s;
    if (t < -1.0) continue;
    sn.x.push_back(t), sn.y.push_back(r->dev_N_m[i]);
    se.x.push_back(t), se.y.push_back(r->dev_E_m[i]);
    sd.x.push_back(t), sd.y.push_back(r->dev_D_m[i]);
    sa.x.push_back(t), sa.y.push_back(r->series.output[i]);
  }
  sa.width_px = 2.5f;
  plot.series = {sn, se, sd, sa};
  if (r->recovery_time_s >= 0) plot.ref_lines.push_back(Ref(render::RefLine::Axis::kVertical, r->recovery_time_s, "recovered"));
  plot.ref_lines.push_back(Ref(render::RefLine::Axis::kHorizontal, spec.recovery_band_m, "band"));
  HEXSIM_RETURN_IF_ERROR(WritePlot(plot, out.File("disturb.png")));
  out.Commit();
  std::fputs(text.c_str(), stdout);
  return Status::Ok();
}

template <typename Args, typename Fn>
void Bind(CLI::App* cmd, std::shared_ptr<Args> args, int* exit_code, Fn fn) {
  cmd->callback([args, exit_code, fn] {
    const Status s = fn(*args);
    *exit_code = s.ok() ? 0 : Report(s);
  });
}

}  // namespace

void AddToolCommands(CLI::App& app, int* exit_code) {
  {
    auto a = std::make_shared<StepArgs>();
    CLI::App* cmd = app.add_subcommand("step", "Step one loop's setpoint at hover; rise, overshoot, settling, error");
    cmd->add_option("--axis", a->axis, "roll|pitch|yaw|alt|vel_N")->required();
    cmd->add_option("--size", a->size, "Step size (deg for angles, m for alt, m/s for vel_N)")->required();
    cmd->add_option("--duration", a->duration_s, "Recorded after the step (s; default 4 for angles, 15 otherwise)");
    AddCommon(cmd, &a->common);
    Bind(cmd, a, exit_code, StepCommand);
  }
  {
    auto a = std::make_shared<FreqArgs>();
    CLI::App* cmd = app.add_subcommand("freqresp", "Multisine at hover: closed-loop Bode plot, bandwidth, margins");
    cmd->add_option("--axis", a->axis, "roll|pitch|yaw|alt|vel_N")->required();
    cmd->add_option("--f-lo", a->f_lo_hz, "Lowest frequency (Hz; default 0.2 angles, 0.05 otherwise)");
    cmd->add_option("--f-hi", a->f_hi_hz, "Highest frequency (Hz; default 8 angles, 3 otherwise)");
    cmd->add_option("--amplitude", a->amplitude, "Multisine peak (axis units; default 4 deg, 8 deg yaw, 0.5)");
    cmd->add_option("--periods", a->periods, "Periods averaged (Welch segments)")->capture_default_str();
    cmd->add_option("--min-coherence", a->min_coherence, "Lines below this coherence are not used")
        ->capture_default_str();
    AddCommon(cmd, &a->common);
    Bind(cmd, a, exit_code, FreqCommand);
  }
  {
    auto a = std::make_shared<DisturbArgs>();
    CLI::App* cmd = app.add_subcommand("disturb", "A wind gust or payload release at hover; peak deviation, recovery");
    cmd->add_option("--gust", a->gust, "Step in the mean wind N,E,D (m/s)");
    cmd->add_option("--gust-duration", a->gust_duration_s, "Gust length (s; 0: stays)")->capture_default_str();
    cmd->add_option("--payload-release", a->payload_release_kg, "Carry this payload (kg) and drop it")
        ->capture_default_str();
    cmd->add_option("--duration", a->after_s, "Recorded after the onset (s)")->capture_default_str();
    cmd->add_option("--band", a->band_m, "Recovered: deviation stays within this (m)")->capture_default_str();
    AddCommon(cmd, &a->common);
    Bind(cmd, a, exit_code, DisturbCommand);
  }
}

}  // namespace hexsim::app
