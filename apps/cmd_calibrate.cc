// hexsim calibrate: compass calibration from plain x,y,z, a FlightLog, an ArduPilot .bin or turntable
// samples. Flags only: reading is logs/mag_input, fitting magnetics/calibrate.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <variant>

#include "cli_util.h"
#include "commands.h"
#include "hexsim/common/atomic_file.h"
#include "hexsim/common/format.h"
#include "hexsim/common/paths.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/logs/mag_input.h"
#include "hexsim/magnetics/calib_io.h"
#include "hexsim/magnetics/calibrate.h"
#include "hexsim/realdata/compass_flight.h"
#include "hexsim/realdata/windows.h"
#include "hexsim/render/figures.h"
#include "hexsim/render/image.h"
#include "hexsim/render/plot.h"

namespace hexsim::app {
namespace {

struct CalibrateArgs {
  std::string samples, method = "auto", out, compass = "mag", units = "auto";
  double field_norm_uT = 0.0;
};

// Samples on three planes before (with the fitted ellipsoid) and after (with the target sphere).
Status WriteBeforeAfterPng(const magnetics::CalibrateOutcome& o, const std::string& path) {
  render::SampleCloud before{"raw", {}, std::nullopt}, after{"calibrated", {}, std::nullopt};
  for (const auto& b : o.raw_uT) {
    const Eigen::Vector3d c = o.field.Correct(b);
    before.points_uT.push_back({b(0), b(1), b(2)});
    after.points_uT.push_back({c(0), c(1), c(2)});
  }
  // |A(raw − b)| = F on the fitted ellipsoid raw = b + F·A⁻¹u, F = ∛det A · r (A = (F/r)K⁻¹, det K = 1).
  const double target = std::cbrt(o.field.A.determinant()) * o.field.radius_uT;
  const Eigen::Matrix3d shape = target * o.field.A.inverse();
  render::Ellipsoid3D fitted, sphere;
  fitted.centre = {o.field.offset_uT(0), o.field.offset_uT(1), o.field.offset_uT(2)};
  fitted.label = "fit";
  sphere.label = "target";
  for (int i = 0; i < 3; ++i) {
    fitted.shape[static_cast<size_t>(i)] = {shape(i, 0), shape(i, 1), shape(i, 2)};
    sphere.shape[static_cast<size_t>(i)] = {i == 0 ? target : 0.0, i == 1 ? target : 0.0, i == 2 ? target : 0.0};
  }
  auto image = render::RenderEllipsoidClouds({before, after}, {fitted, sphere});
  if (!image.ok()) return image.status();
  return render::WritePng(*image, path);
}

// A log's field norm before (raw) and after calibration against time and against battery current:
// a current-driven field shows as a norm that follows the current (PX4 Flight Review's norm-vs-thrust
// view). At most kNormPlotPoints points per series (evenly thinned).
Status WriteFieldNormPng(const magnetics::CalibrateOutcome& o, const logs::MagInput& input, const std::string& path) {
  constexpr size_t kNormPlotPoints = 4000;
  const size_t n = o.raw_uT.size();
  const bool has_current = input.current_A.size() == n;
  const size_t step = std::max<size_t>(1, n / kNormPlotPoints);
  render::Series before_t{"as read", {}, {}, render::PaletteColour(0)}, after_t{"calibrated", {}, {}, render::PaletteColour(1)};
  render::Series before_i = before_t, after_i = after_t;
  for (auto* s : {&before_i, &after_i}) {
    s->style = render::SeriesStyle::kScatter;
    s->marker_px = 2.5f;
  }
  for (size_t i = 0; i < n; i += step) {
    magnetics::CompensatorInput in;
    if (input.control_u.size() == n) in.control_u = input.control_u[i];
    if (has_current && std::isfinite(input.current_A[i])) in.current_A = input.current_A[i];
    const double raw = o.raw_uT[i].norm(), after = o.compensator->Correct(o.raw_uT[i], in).norm();
    before_t.x.push_back(input.t_s[i]);
    before_t.y.push_back(raw);
    after_t.x.push_back(input.t_s[i]);
    after_t.y.push_back(after);
    if (has_current) {
      before_i.x.push_back(input.current_A[i]);
      before_i.y.push_back(raw);
      after_i.x.push_back(input.current_A[i]);
      after_i.y.push_back(after);
    }
  }
  render::Figure fig;
  fig.title = "field norm before and after calibration";
  const auto panel = [](const char* against, const char* x_label, render::Series before, render::Series after) {
    render::Plot2D p;
    p.title = std::string("|B| against ") + against;
    p.x_label = x_label;
    p.y_label = "|B| (uT)";
    p.series = {std::move(before), std::move(after)};
    return p;
  };
  fig.panels.emplace_back(panel("time", "time (s)", before_t, after_t));
  if (has_current) fig.panels.emplace_back(panel("battery current", "current (A)", before_i, after_i));
  // The Earth field where and when the log flew (WMM), where the flight fit had it.
  const double wmm_uT = o.flight ? o.flight->in.options.prior_field_N_uT.norm() : 0.0;
  if (wmm_uT > 0.0) {
    for (auto& p : fig.panels) {
      std::get<render::Plot2D>(p).ref_lines.push_back({render::RefLine::Axis::kHorizontal, wmm_uT, "WMM", {}});
    }
  }
  fig.cols = static_cast<int>(fig.panels.size());
  auto image = render::Render(fig, 700 * fig.cols, 520);
  if (!image.ok()) return image.status();
  return render::WritePng(*image, path);
}

// The in-flight model's samples and fit (realdata: windows, timing, regressor), from the log the
// input came with.
Status PrepareFlightFit(const logs::MagInput& input, const std::string& compass, magnetics::FlightContext* fc) {
  if (!input.log) return Status::Ok();  // not a flight log: the flight path says so when asked for
  const logs::FlightLog& log = *input.log;
  const realdata::FlightWindows w = realdata::FindFlightWindows(log);
  auto cf = realdata::FitCompassInFlight(log, input, w);
  if (!cf.ok()) return cf.status();
  magnetics::PreparedFlightFit p;
  p.samples = std::move(cf->samples);
  p.index = std::move(cf->index);
  p.options = cf->options;
  p.fit = std::move(cf->fit);
  p.windows_note = cf->windows_note;
  p.flight_only = cf->flight_only;
  p.tilted = cf->tilted;
  p.outside = cf->outside;
  p.timing_note = realdata::TimingNote(*cf);
  p.current_shift_s = cf->current_shift_s;
  p.current_shift_range_s[0] = cf->current_shift_range_s[0];
  p.current_shift_range_s[1] = cf->current_shift_range_s[1];
  p.current_note = cf->current_note;
  p.current_per_throttle_A = cf->current_per_throttle_A;
  p.ground_run_note = cf->ground_run_note;
  fc->prepared = std::move(p);
  fc->motor_compensation = realdata::MotorCompensationOf(log, compass);
  return Status::Ok();
}

// The flight path's lines: windows, samples, residual, timing, the disturbance term.
void PrintFlight(const magnetics::FlightOutcome& fo) {
  const magnetics::FlightFit& fit = fo.in.fit;
  const std::string field = fo.in.options.field_free
                                ? Format("Earth field fitted freely (no place and date): %.1f uT", fit.field_N_uT.norm())
                                : Format("Earth field %+.1f %% vs WMM", 100 * fo.field_norm_vs_wmm);
  std::printf("flight fit: %s; %d samples in %d blocks of %.1f s; residual %.2f -> %.2f uT RMS per axis; %s\n",
              fo.in.windows_note.c_str(), fit.samples_used, fit.blocks, fo.in.options.block_s, fit.rms_prior_uT,
              fit.rms_after_uT, field.c_str());
  std::printf("timing: %s\n", fo.in.timing_note.c_str());
  if (!fit.term_fitted) return;
  const bool throttle = fit.form == magnetics::FlightTermForm::kThrottle;
  const char* state = fo.term_applied ? "written as the autopilots' compensation" : "not applied";
  if (!fo.term_plausible) {
    std::printf("%s field: outside its physical range: model mismatch (%s)\n", throttle ? "throttle" : "current", state);
  } else {
    std::printf("%s field: %.1f %s [%.1f, %.1f] (95 %%, block jackknife; %s)\n", throttle ? "throttle" : "current",
                10 * fit.term_norm_uT, throttle ? "mG per unit throttle" : "mG/A", 10 * fit.term_norm_ci95[0],
                10 * fit.term_norm_ci95[1], state);
  }
  if (throttle) {
    const double slope = std::fabs(fo.in.current_per_throttle_A);
    if (std::isfinite(slope) && slope > 0) {
      std::printf("current equivalent: %.1f mG/A [%.1f, %.1f] through the log's current-vs-throttle slope %.1f A per unit "
                  "throttle\n",
                  10 * fit.term_norm_uT / slope, 10 * fit.term_norm_ci95[0] / slope, 10 * fit.term_norm_ci95[1] / slope,
                  fo.in.current_per_throttle_A);
    } else {
      std::printf("current equivalent: none (%s)\n",
                  fo.in.current_note.empty() ? "no current-vs-throttle slope in the log"
                                             : ("the current is unusable: " + fo.in.current_note).c_str());
    }
  }
  std::printf("parameters: %s\n", fo.motor_params_note.c_str());
}

Status CalibrateCommand(const CalibrateArgs& a, int* exit_code) {
  auto input = logs::ReadMagInput(a.samples, a.compass);
  if (!input.ok()) return input.status();
  magnetics::CalibrateRequest rq;
  rq.method = a.method;
  rq.units = a.units == "auto" && !input->units.empty() ? input->units : a.units;
  rq.field_norm_uT = a.field_norm_uT;
  rq.compass_index = logs::CompassIndex(a.compass);
  rq.prior_offset = input->prior_offset;
  rq.px4_index = input->px4_index;
  std::vector<magnetics::MagSample> samples(input->field.size());
  for (size_t i = 0; i < samples.size(); ++i) {
    samples[i].mag_B_uT = input->field[i];
    if (!input->control_u.empty()) samples[i].control_u = input->control_u[i];
    if (!input->current_A.empty()) samples[i].current_A = input->current_A[i];
    if (!input->angle_deg.empty()) samples[i].angle_deg = input->angle_deg[i];
    if (!input->plane.empty()) samples[i].plane = input->plane[i];
    if (!input->q_wxyz.empty()) {
      const Eigen::Vector4d& q = input->q_wxyz[i];
      samples[i].q_NB = Eigen::Quaterniond(q(0), q(1), q(2), q(3));
    }
  }
  magnetics::FlightContext& fc = rq.flight;
  fc.has_attitude = !input->q_wxyz.empty() && input->t_s.size() == input->field.size();
  fc.body_from_raw = input->body_from_raw;
  fc.soft_iron_in_force = input->soft_iron_in_force;
  fc.has_place = input->has_place;
  fc.px4_comp_type = input->px4_comp_type;
  fc.px4_comp_G = input->px4_comp_G;
  // Without a place (no GPS fix) the flight fit takes the Earth field as free terms; auto still
  // prefers it only where the WMM gives the field.
  if (fc.has_attitude && (a.method == "flight" || (a.method == "auto" && fc.has_place))) {
    const Status prepared = PrepareFlightFit(*input, a.compass, &fc);
    // auto falls back to the free-hand fits when the flight model cannot fit; flight says why.
    if (!prepared.ok() && a.method == "flight") return prepared.WithContext(a.samples);
    if (!prepared.ok()) input->notes.push_back("flight fit not possible: " + prepared.message());
  }
  auto o = magnetics::Calibrate(std::move(samples), rq);
  if (!o.ok()) return o.status().WithContext(a.samples);
  o->report["input"] = {{"file", a.samples}, {"format", input->format}, {"compass", a.compass}, {"notes", input->notes}};
  HEXSIM_RETURN_IF_ERROR(EnsureDirectory(DirName(a.out)));
  const std::string base = DirName(a.out) + "/" + FileStem(a.out);
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(base + ".report.json", o->report.dump(2) + "\n"));
  // Autopilot parameter files only for an accepted fit: a rejected one must not look loadable (one
  // left by an earlier run at this path is removed too). calib.yaml and the report say what failed.
  const bool accepted = o->exit_code == 0;
  if (accepted) {
    HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(base + ".parm", magnetics::ArduPilotParmText(o->ardupilot, "hexsim calibrate", o->param_comments)));
    HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(base + ".params", magnetics::Px4ParamsText(o->px4, "hexsim calibrate", o->param_comments)));
  } else {
    std::error_code ec;
    std::filesystem::remove(base + ".parm", ec);
    std::filesystem::remove(base + ".params", ec);
  }
  HEXSIM_RETURN_IF_ERROR(WriteBeforeAfterPng(*o, base + ".png"));
  // A log (samples with times): the norm against time and current, before and after.
  const bool timed = input->t_s.size() == o->raw_uT.size() && !o->raw_uT.empty();
  if (timed) HEXSIM_RETURN_IF_ERROR(WriteFieldNormPng(*o, *input, base + ".norm.png"));
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(a.out, magnetics::CompensatorToYamlText(*o->compensator)));
  for (const auto& n : input->notes) std::printf("input: %s\n", n.c_str());
  const auto& f = o->field;
  std::printf("units: %s\nmethod: %s (%s)\n", o->units.assumption.c_str(), f.method_used.c_str(), f.why.c_str());
  std::printf("coverage eigenvalues: %.3f %.3f %.3f; norm spread %.2f %% -> %.2f %%; fitness %.3f uT\n",
              f.coverage.eigenvalues(0), f.coverage.eigenvalues(1), f.coverage.eigenvalues(2),
              100 * f.norm_spread_before, 100 * f.norm_spread_after, f.fitness_uT);
  std::printf("offset %.3f %.3f %.3f uT\n", f.offset_uT(0), f.offset_uT(1), f.offset_uT(2));
  if (f.OffsetAxisUndetermined()) {
    const Eigen::Vector3d& n = f.undetermined_axis;
    std::printf("offset along the spin axis (body %+.3f %+.3f %+.3f): UNDETERMINED by a flat spin (%.2f uT carried, not "
                "measured)\n",
                n(0), n(1), n(2), n.dot(f.offset_uT));
  }
  if (o->flight) PrintFlight(*o->flight);
  for (const auto& w : f.warnings) std::printf("warning: %s\n", w.c_str());
  std::printf("calibrate: %s -> %s (+ %s)\n", accepted ? "accepted" : "REJECTED by its gate", a.out.c_str(),
              accepted ? (timed ? ".report.json .parm .params .png .norm.png" : ".report.json .parm .params .png")
                       : (timed ? ".report.json .png .norm.png; no .parm/.params for a rejected fit"
                                : ".report.json .png; no .parm/.params for a rejected fit"));
  *exit_code = o->exit_code;
  return Status::Ok();
}

}  // namespace

void AddCalibrateCommand(CLI::App& app, int* exit_code) {
  auto a = std::make_shared<CalibrateArgs>();
  CLI::App* c = app.add_subcommand("calibrate", "Fit a compass calibration -> calib.yaml, .report.json, .parm, .params, .png");
  c->add_option("samples", a->samples, "x,y,z text, FlightLog CSV, samples.csv, ArduPilot .bin or PX4 .ulg (detected from content)")
      ->required();
  c->add_option("--method", a->method,
                "auto|sphere|ellipsoid|robust|robust-sphere|robust-ellipsoid|flight|none|traditional|adaptive|adaptive-current|"
                "compassmot|px4-ls")
      ->capture_default_str();
  c->add_option("--compass", a->compass, "Which compass: mag, mag2, mag3")->capture_default_str();
  c->add_option("--units", a->units, "auto|uT|mG|G|nT|counts")->capture_default_str();
  c->add_option("--field-norm", a->field_norm_uT, "Local field norm in uT (e.g. from hexsim field); needed with counts");
  c->add_option("--out", a->out, "calib.yaml to write")->required();
  c->callback([a, exit_code] {
    const Status s = CalibrateCommand(*a, exit_code);
    if (!s.ok()) *exit_code = Report(s);
  });
}

}  // namespace hexsim::app
