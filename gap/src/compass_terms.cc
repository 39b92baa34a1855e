#include "compass_terms_fit.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/LU>
#include <fmt/format.h>

#include "hexsim/common/plausibility.h"
#include "hexsim/common/statistics.h"
#include "hexsim/logs/mag_input.h"
#include "hexsim/magnetics/current_field.h"
#include "hexsim/magnetics/flight_fit.h"
#include "hexsim/realdata/compass_flight.h"

namespace hexsim::gap {
namespace internal {
namespace {

using Eigen::Vector3d;

nlohmann::json Vec(const Vector3d& v) { return {v(0), v(1), v(2)}; }

// The vehicle file's field per ampere of battery current at compass c (body frame), the motors
// sharing it equally (the hover point: equal outputs).
Vector3d ModelledPerAmp(const vehicle::VehicleParams& v, size_t c) {
  magnetics::Currents cur;
  cur.battery_A = 1.0;
  const size_t n = v.rotors.size();
  cur.motor_A.assign(n, n > 0 ? 1.0 / static_cast<double>(n) : 0.0);
  return magnetics::CurrentDrivenField_uT(v.wiring, v.compasses[c].position_B_m, cur);
}

// |g| and its 95 % interval for g = d − m with the jackknife covariance of d (m fixed), by the
// absolute term's own rule (magnetics::TermNormOf). With nothing modelled (m = 0) it is the absolute
// term's interval.
void GapInterval(const Eigen::Matrix3d& cov, int blocks, CompassTerms* t) {
  const magnetics::TermNorm tn = magnetics::TermNormOf(t->gap_uT_per_A, cov, blocks);
  t->gap_norm_uT_per_A = tn.norm;
  t->gap_norm_ci95_uT_per_A[0] = tn.ci95[0];
  t->gap_norm_ci95_uT_per_A[1] = tn.ci95[1];
}

// The parameters to paste: offsets where plausible, the compensation (autopilot_params.h).
void Parameters(const logs::MagInput& in, int index, const logs::FlightLog& log, CompassTerms* t) {
  if (!t->gate_accepted) return;  // as calibrate: no parameter file for a fit its gate rejects
  const bool throttle = t->form == "throttle";
  // CompensationParams owns the no-flight rule (ground_run_note: neither written nor zeroed).
  t->motor = magnetics::CompensationParams(index, in.px4_index, t->term_fitted,
                                           t->term_fitted && t->term_resolved && t->term_plausible, throttle, t->term_uT,
                                           t->term_ci_half_uT, in.body_from_raw.inverse(),
                                           realdata::MotorCompensationOf(log, t->channel), in.px4_comp_type, in.px4_comp_G,
                                           t->ground_run_note);
  if (t->offset_plausible) {
    t->ardupilot = magnetics::ArduPilotCompassParams(t->offset_uT, in.soft_iron_in_force, index);
    t->px4 = magnetics::Px4CompassParams(t->offset_uT, in.soft_iron_in_force, in.px4_index >= 0 ? in.px4_index : index);
  }
}

}  // namespace

Result<CompassTerms> FitCompassTerms(const logs::FlightLog& log, const vehicle::VehicleParams& v, size_t c,
                                     const std::string& name, const realdata::FlightWindows& windows, uint64_t seed,
                                     const realdata::LagEstimate* staleness) {
  auto in = logs::MagInputFromFlightLog(log, log.meta.value("source", std::string("log")), name);
  if (!in.ok()) return in.status();
  realdata::CompassFlightOptions o;
  o.seed = seed;
  o.staleness = staleness;
  auto cf = realdata::FitCompassInFlight(log, *in, windows, o);
  if (!cf.ok()) return cf.status();
  const magnetics::FlightFit& f = cf->fit;
  CompassTerms t;
  t.channel = name;
  t.form = magnetics::FlightTermFormName(f.form);
  t.current_note = cf->current_note;
  const Eigen::Matrix3d Minv = in->body_from_raw.inverse();
  t.offset_uT = Minv * f.offset_y_uT;
  t.offset_ci_half_uT = (Minv.cwiseAbs() * f.offset_ci_half_uT);
  t.offset_plausible = plausibility::IsPlausible("compass_offset", t.offset_uT.norm());
  t.field_N_uT = f.field_N_uT;
  t.field_ci_half_uT = f.field_ci_half_uT;
  t.wmm_field_N_uT = cf->options.prior_field_N_uT;
  t.term_fitted = f.term_fitted;
  t.term_resolved = f.term_resolved;
  t.term_note = f.term_note;
  t.term_uT = f.term_uT;
  t.term_ci_half_uT = f.term_ci_half_uT;
  t.term_norm_uT = f.term_norm_uT;
  t.term_norm_ci95_uT[0] = f.term_norm_ci95[0];
  t.term_norm_ci95_uT[1] = f.term_norm_ci95[1];
  const bool throttle = f.form == magnetics::FlightTermForm::kThrottle;
  t.term_plausible = plausibility::IsPlausible(throttle ? "throttle_hard_iron" : "current_hard_iron", f.term_norm_uT);
  if (throttle && std::isfinite(cf->current_per_throttle_A) && std::fabs(cf->current_per_throttle_A) > 0) {
    const double s = std::fabs(cf->current_per_throttle_A);
    t.current_equivalent_uT_per_A = f.term_norm_uT / s;
    t.current_equivalent_ci95_uT_per_A[0] = f.term_norm_ci95[0] / s;
    t.current_equivalent_ci95_uT_per_A[1] = f.term_norm_ci95[1] / s;
  }
  if (!throttle && f.term_fitted && c < v.compasses.size()) {
    t.modelled_available = true;
    t.modelled_uT_per_A = ModelledPerAmp(v, c);
    t.gap_uT_per_A = f.term_uT - t.modelled_uT_per_A;
    GapInterval(f.term_cov, f.blocks, &t);
  }
  t.latency_s = cf->latency_s;
  t.latency_applied = cf->latency_applied;
  t.current_shift_s = cf->current_shift_s;
  t.current_shift_range_s[0] = cf->current_shift_range_s[0];
  t.current_shift_range_s[1] = cf->current_shift_range_s[1];
  t.timing_note = realdata::TimingNote(*cf);
  t.ground_run_note = cf->ground_run_note;
  t.windows_note = cf->windows_note;
  t.flight_only = cf->flight_only;
  t.samples = f.samples_used;
  t.blocks = f.blocks;
  t.without_regressor = f.without_regressor;
  t.block_s = cf->options.block_s;
  t.rms_before_uT = f.rms_prior_uT;
  t.rms_after_uT = f.rms_after_uT;
  const bool applied = t.term_fitted && t.term_resolved && t.term_plausible && t.ground_run_note.empty();
  t.fitness_uT = magnetics::FlightFitness_uT(f, cf->samples, applied);
  t.gate_accepted = t.fitness_uT <= magnetics::kMaxFlightFitness_uT && t.offset_plausible;
  Parameters(*in, logs::CompassIndex(name), log, &t);
  return t;
}

std::string CurrentEquivalentRefusal(const Result<CompassTerms>& terms, double equivalent_uT_per_A) {
  const double v = equivalent_uT_per_A;
  if (!terms.ok()) return "the in-flight model did not fit (" + terms.status().message() + ")";
  if (terms->form != "current") return "the current is unusable (" + terms->current_note + ")";
  if (!terms->term_fitted) return "the in-flight model fitted no current term (" + terms->term_note + ")";
  if (v < terms->term_norm_ci95_uT[0] || v > terms->term_norm_ci95_uT[1]) {
    const double k = kMilliGaussPerMicroTesla;
    return fmt::format("its current equivalent {:.1f} mG/A lies outside the in-flight model's current term {:.1f} [{:.1f}, "
                       "{:.1f}] mG/A on the same log: the field follows the throttle, not the current",
                       k * v, k * terms->term_norm_uT, k * terms->term_norm_ci95_uT[0], k * terms->term_norm_ci95_uT[1]);
  }
  return "";
}

CurrentShift PredictionCurrentShift(const Result<CompassTerms>& terms, const realdata::LagEstimate& scan,
                                    double scan_shift_s, const std::vector<double>& grid) {
  CurrentShift out{scan_shift_s, scan};
  if (!terms.ok() || terms->form != "current" || !terms->term_fitted || !terms->term_resolved || grid.size() < 2) {
    return out;
  }
  const double step = grid[1] - grid[0];
  out.value_s = terms->current_shift_s;
  out.plug_in.value_s = terms->current_shift_s;
  out.plug_in.ci95_s[0] = terms->current_shift_range_s[0] - step;
  out.plug_in.ci95_s[1] = terms->current_shift_range_s[1] + step;
  return out;
}

nlohmann::json CompassTermsJson(const CompassTerms& t) {
  const double k = kMilliGaussPerMicroTesla;
  nlohmann::json j = {{"model", "in-flight compass model (magnetics/flight_fit.h), as hexsim calibrate --method flight"},
                      {"form", t.form},
                      {"current_note", t.current_note},
                      {"ground_run_note", t.ground_run_note},
                      {"offset_uT", Vec(t.offset_uT)},
                      {"offset_ci95_half_uT", Vec(t.offset_ci_half_uT)},
                      {"offset_plausible", t.offset_plausible},
                      {"offset_physical_range", plausibility::RangeText("compass_offset")},
                      {"fitness_uT", t.fitness_uT},
                      {"gate", {{"accepted", t.gate_accepted},
                                {"max_fitness_uT", magnetics::kMaxFlightFitness_uT},
                                {"rule", "as hexsim calibrate --method flight: fitness (RMS of |calibrated| - |field|) "
                                         "within ArduPilot's relaxed COMPASS_CAL_FIT and the offset plausible; a rejected "
                                         "compass gets no parameters"}}},
                      {"field_N_uT", Vec(t.field_N_uT)},
                      {"field_ci95_half_uT", Vec(t.field_ci_half_uT)},
                      {"wmm_field_N_uT", Vec(t.wmm_field_N_uT)},
                      {"samples", t.samples},
                      {"blocks", t.blocks},
                      {"block_s", t.block_s},
                      {"without_regressor", t.without_regressor},
                      {"residual_rms_before_uT", t.rms_before_uT},
                      {"residual_rms_after_uT", t.rms_after_uT},
                      {"interval_method", t.interval_method},
                      {"held_out", t.held_out},
                      {"windows", t.windows_note},
                      {"timing", {{"latency_s", t.latency_s},
                                  {"latency_applied", t.latency_applied},
                                  {"current_shift_s", t.current_shift_s},
                                  {"current_shift_range_s", {t.current_shift_range_s[0], t.current_shift_range_s[1]}},
                                  {"note", t.timing_note}}}};
  const bool throttle = t.form == "throttle";
  nlohmann::json term = {{"fitted", t.term_fitted},
                         {"resolved", t.term_resolved},
                         {"plausible", t.term_plausible},
                         {"physical_range", plausibility::RangeText(throttle ? "throttle_hard_iron" : "current_hard_iron")},
                         {"note", t.term_note}};
  const std::string u = throttle ? "per_throttle" : "per_A";
  term["uT_" + u] = Vec(t.term_uT);
  term["ci95_half_uT_" + u] = Vec(t.term_ci_half_uT);
  term["norm_uT_" + u] = t.term_norm_uT;
  term["norm_mG_" + u] = k * t.term_norm_uT;
  term["norm_ci95_uT_" + u] = {t.term_norm_ci95_uT[0], t.term_norm_ci95_uT[1]};
  term["norm_ci95_mG_" + u] = {k * t.term_norm_ci95_uT[0], k * t.term_norm_ci95_uT[1]};
  if (std::isfinite(t.current_equivalent_uT_per_A)) {
    term["current_equivalent_uT_per_A"] = t.current_equivalent_uT_per_A;
    term["current_equivalent_ci95_uT_per_A"] = {t.current_equivalent_ci95_uT_per_A[0], t.current_equivalent_ci95_uT_per_A[1]};
  }
  j[throttle ? "throttle_term" : "current_term"] = term;
  if (t.modelled_available) {
    j["gap"] = {{"modelled_uT_per_A", Vec(t.modelled_uT_per_A)},
                {"modelled_norm_mG_per_A", k * t.modelled_uT_per_A.norm()},
                {"gap_uT_per_A", Vec(t.gap_uT_per_A)},
                {"norm_mG_per_A", k * t.gap_norm_uT_per_A},
                {"norm_ci95_mG_per_A", {k * t.gap_norm_ci95_uT_per_A[0], k * t.gap_norm_ci95_uT_per_A[1]}},
                {"definition", "absolute current term minus the vehicle file's modelled field per ampere at this compass "
                               "(battery current shared equally by the motors)"}};
  }
  nlohmann::json ap = nlohmann::json::object(), px = nlohmann::json::object();
  for (const auto& [n, v] : t.ardupilot) ap[n] = v;
  for (const auto& [n, v] : t.motor.ardupilot) ap[n] = v;
  for (const auto& [n, v] : t.px4) px[n] = v;
  for (const auto& [n, v] : t.motor.px4) px[n] = v;
  j["parameters"] = {{"compensation", t.motor.action}, {"note", t.motor.comment}, {"ardupilot", ap}, {"px4", px}};
  return j;
}

std::string CompassTermsText(const CompassTerms& t) {
  const double k = kMilliGaussPerMicroTesla;
  const bool throttle = t.form == "throttle";
  const char* what = throttle ? "throttle field" : "current field";
  std::string s = "  absolute (in-flight model, as hexsim calibrate; every flight block): ";
  if (!t.term_fitted) return s + fmt::format("{} not fitted: {}", what, t.term_note);
  if (!t.term_plausible) {
    return s + fmt::format("{} outside its physical range ({}): model mismatch", what,
                           plausibility::RangeText(throttle ? "throttle_hard_iron" : "current_hard_iron"));
  }
  s += fmt::format("{} {:.1f} {} [{:.1f}, {:.1f}] (95 %, block jackknife){}", what, k * t.term_norm_uT,
                   throttle ? "mG per unit throttle" : "mG/A", k * t.term_norm_ci95_uT[0], k * t.term_norm_ci95_uT[1],
                   t.term_resolved ? "" : ", not resolved from zero");
  if (std::isfinite(t.current_equivalent_uT_per_A) &&
      plausibility::IsPlausible("current_hard_iron", t.current_equivalent_uT_per_A)) {
    s += fmt::format(" = {:.1f} mG/A through the log's current-vs-throttle slope", k * t.current_equivalent_uT_per_A);
  }
  if (t.modelled_available && !(plausibility::IsPlausible("current_hard_iron", t.modelled_uT_per_A.norm()) &&
                                 plausibility::IsPlausible("current_hard_iron", t.gap_norm_uT_per_A))) {
    s += "; the vehicle file's modelled field or the gap is outside current_hard_iron's range: model mismatch";
  } else if (t.modelled_available) {
    s += fmt::format("; vehicle file models {:.1f} mG/A: gap {:.1f} mG/A [{:.1f}, {:.1f}]", k * t.modelled_uT_per_A.norm(),
                     k * t.gap_norm_uT_per_A, k * t.gap_norm_ci95_uT_per_A[0], k * t.gap_norm_ci95_uT_per_A[1]);
  }
  return s;
}

}  // namespace internal

ParamFiles CompassParamFiles(const std::vector<CompassTerms>& terms) {
  magnetics::ParamList ap, px;
  std::vector<std::string> comments;
  bool motct_written = false;
  for (const CompassTerms& t : terms) {
    if (!t.gate_accepted) {
      comments.push_back(fmt::format("{}: no parameters: fitness {:.2f} uT above {:.1f} uT or offset out of range "
                                     "(hexsim calibrate's gate rejects this fit)",
                                     t.channel, t.fitness_uT, magnetics::kMaxFlightFitness_uT));
      continue;
    }
    if (t.ardupilot.empty() && t.motor.ardupilot.empty()) continue;
    ap.insert(ap.end(), t.ardupilot.begin(), t.ardupilot.end());
    px.insert(px.end(), t.px4.begin(), t.px4.end());
    for (const auto& p : t.motor.ardupilot) {
      // COMPASS_MOTCT is one parameter for every compass: written once (the forms agree: one log).
      if (p.first == "COMPASS_MOTCT" && motct_written) continue;
      motct_written = motct_written || p.first == "COMPASS_MOTCT";
      ap.push_back(p);
    }
    for (const auto& p : t.motor.px4) {
      if (std::find_if(px.begin(), px.end(), [&](const auto& q) { return q.first == p.first; }) == px.end()) px.push_back(p);
    }
    comments.push_back(t.channel + ": " + t.motor.comment);
    if (!t.offset_plausible) comments.push_back(t.channel + ": offsets not written: outside their physical range (model mismatch)");
  }
  ParamFiles f;
  if (ap.empty() && px.empty()) return f;
  f.parm = magnetics::ArduPilotParmText(ap, "hexsim gap diagnose", comments);
  f.params = magnetics::Px4ParamsText(px, "hexsim gap diagnose", comments);
  return f;
}

}  // namespace hexsim::gap
