// `hexsim calibrate` on a flight log with an attitude: the attitude-aided fit of flight_fit.h,
// reported with the same keys as every method, plus the autopilots' current compensation.
#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <fmt/format.h>

#include "calibrate_internal.h"
#include "hexsim/common/plausibility.h"
#include "hexsim/magnetics/calibrate.h"
#include "hexsim/magnetics/compensators.h"

namespace hexsim::magnetics {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

using internal::Vec;

// The acceptance gate (flight_fit.h, shared with gap's parameter files): beyond kMaxFlightFitness_uT
// the fit is reported but rejected (exit 1).
constexpr double kMaxFitness_uT = kMaxFlightFitness_uT;

}  // namespace

bool UsesFlightPath(const std::vector<MagSample>& samples, const CalibrateRequest& rq) {
  // Without a place the prepared fit has fitted the Earth field freely (flight_fit.h field_free).
  return rq.flight.has_attitude && rq.flight.prepared.has_value() && !HasTurntableColumns(samples);
}

namespace {

// The disturbance term: its report entry, the warning why it is not applied, and whether it is.
nlohmann::json TermReport(const FlightFit& fit, const PreparedFlightFit& pf, FlightOutcome* fo, FieldCalibration* f) {
  const bool throttle = fit.form == FlightTermForm::kThrottle;
  const char* row = throttle ? "throttle_hard_iron" : "current_hard_iron";
  const char* unit = throttle ? "mG/throttle" : "mG/A";
  fo->term_plausible = plausibility::IsPlausible(row, fit.term_norm_uT);
  const bool resolved = fit.term_fitted && fit.term_resolved;
  nlohmann::json cur = {{"form", FlightTermFormName(fit.form)},
                        {"fitted", fit.term_fitted},
                        {"regressor_span", fit.regressor_span},
                        {"without_regressor", fit.without_regressor},
                        {"physical_range", plausibility::RangeText(row)},
                        {"plausible", fo->term_plausible},
                        {"resolved", resolved},
                        {"max_abs_t", fit.term_max_abs_t},
                        {"t_threshold", fit.term_t_threshold},
                        {"note", fit.term_note},
                        {"current_note", pf.current_note}};
  if (throttle) {
    cur["uT_per_throttle"] = Vec(fit.term_uT);
    cur["norm_mG_per_throttle"] = 10 * fit.term_norm_uT;
    cur["norm_ci95_mG_per_throttle"] = {10 * fit.term_norm_ci95[0], 10 * fit.term_norm_ci95[1]};
    // A throttle term's current equivalent only through the log's own current-vs-throttle slope, and
    // only where the current is usable (realdata::CompassFlight::current_per_throttle_A, NaN otherwise).
    const double slope = std::fabs(pf.current_per_throttle_A);
    if (fit.term_fitted && std::isfinite(slope) && slope > 0) {
      cur["current_equivalent_mG_per_A"] = 10 * fit.term_norm_uT / slope;
      cur["current_equivalent_ci95_mG_per_A"] = {10 * fit.term_norm_ci95[0] / slope, 10 * fit.term_norm_ci95[1] / slope};
      cur["current_per_throttle_A"] = pf.current_per_throttle_A;
    } else {
      cur["current_equivalent_note"] = pf.current_note.empty() ? "no current-vs-throttle slope in the log"
                                                               : "none: the current is unusable (" + pf.current_note + ")";
    }
  } else {
    cur["current_span_A"] = fit.regressor_span;
    cur["uT_per_A"] = Vec(fit.term_uT);
    cur["ci95_half_uT_per_A"] = Vec(fit.term_ci_half_uT);
    cur["norm_mG_per_A"] = 10 * fit.term_norm_uT;
    cur["norm_ci95_mG_per_A"] = {10 * fit.term_norm_ci95[0], 10 * fit.term_norm_ci95[1]};
  }
  if (!fit.term_fitted) {
    f->warnings.push_back(fmt::format("{} compensation not fitted: {}", throttle ? "throttle" : "current", fit.term_note));
  } else if (!fo->term_plausible) {
    f->warnings.push_back(fmt::format("{} field {:.1f} {} outside its physical range ({}): model mismatch, not applied",
                                      throttle ? "throttle" : "current", 10 * fit.term_norm_uT, unit,
                                      plausibility::RangeText(row)));
  } else if (!resolved) {
    f->warnings.push_back(fmt::format("{} field {:.1f} {} [{:.1f}, {:.1f}]: not resolved from zero (largest |t| {:.1f} < "
                                      "{:.1f}), not applied",
                                      throttle ? "throttle" : "current", 10 * fit.term_norm_uT, unit,
                                      10 * fit.term_norm_ci95[0], 10 * fit.term_norm_ci95[1], fit.term_max_abs_t,
                                      fit.term_t_threshold));
  }
  if (!pf.current_note.empty()) f->warnings.push_back("current not used: " + pf.current_note);
  fo->term_applied = resolved && fo->term_plausible && pf.ground_run_note.empty();
  if (resolved && fo->term_plausible && !fo->term_applied) {
    f->warnings.push_back(fmt::format("{} field {:.1f} {} fitted {}: not applied (a flight's relation of field to {} is "
                                      "not a ground run's; the log's own compensation is kept)",
                                      throttle ? "throttle" : "current", 10 * fit.term_norm_uT, unit, pf.ground_run_note,
                                      throttle ? "throttle" : "current"));
  }
  cur["ground_run_note"] = pf.ground_run_note;
  cur["applied"] = fo->term_applied;
  return cur;
}

}  // namespace

Result<CalibrateOutcome> FlightPath(CalibrateOutcome out, const std::vector<MagSample>& /*samples*/,
                                    const CalibrateRequest& rq) {
  const FlightContext& fc = rq.flight;
  if (!fc.has_attitude) {
    return Status::BadInput("--method flight: the input has no attitude (it needs a flight log: FlightLog CSV, .bin or .ulg)");
  }
  if (!fc.prepared) return Status::BadInput("--method flight: the log's rows are needed (windows and timing)");
  const PreparedFlightFit& pf = *fc.prepared;
  const FlightFit* fit = &pf.fit;
  const Vector3d* prior = &pf.options.prior_field_N_uT;
  const Matrix3d M = fc.body_from_raw;
  FlightOutcome fo;
  fo.in = pf;

  FieldCalibration& f = out.field;
  f.method_used = "flight";
  f.why = rq.method == "flight" ? "requested"
                                : "a flight log with an attitude and a place: attitude-aided fit against the WMM field "
                                  "(orientation coverage matters less: the attitude says where the field points)";
  const Matrix3d Minv = M.inverse();
  f.offset_uT = Minv * fit->offset_y_uT;
  f.A = M;
  f.K = Minv / std::cbrt(Minv.determinant());
  f.radius_uT = fit->field_N_uT.norm();
  f.coverage = internal::CoverageAboutMedianNorm(out.raw_uT);
  f.norm_spread_before = NormSpread(out.raw_uT);

  // The disturbance term is applied only when it is resolved (interval excludes 0) and plausible.
  nlohmann::json cur = TermReport(*fit, pf, &fo, &f);
  const Vector3d d = fo.term_applied ? fit->term_uT : Vector3d::Zero();
  const bool throttle = fit->form == FlightTermForm::kThrottle;
  std::vector<Vector3d> after;
  for (size_t k = 0; k < pf.index.size(); ++k) {
    const double r = throttle ? pf.samples[k].throttle : pf.samples[k].current_A;
    after.emplace_back(f.Correct(out.raw_uT[pf.index[k]]) - d * (std::isfinite(r) ? r : 0.0));
  }
  f.norm_spread_after = NormSpread(after);
  f.fitness_uT = FlightFitness_uT(*fit, pf.samples, fo.term_applied);
  const bool free_field = pf.options.field_free;
  const double wmm_norm = prior->norm();
  const double norm_diff = free_field ? std::nan("") : f.radius_uT / wmm_norm - 1.0;
  if (free_field) {
    f.warnings.push_back(fmt::format("no place and date (no GPS fix): Earth field fitted freely, {:.1f} uT{}", f.radius_uT,
                                     plausibility::IsPlausible("earth_field_norm", f.radius_uT)
                                         ? ""
                                         : fmt::format(", outside {}: model mismatch", plausibility::RangeText("earth_field_norm"))));
  }
  if (!plausibility::IsPlausible("compass_offset", f.offset_uT.norm())) {
    f.warnings.push_back(fmt::format("offset {:.1f} uT outside {}: model mismatch", f.offset_uT.norm(),
                                     plausibility::RangeText("compass_offset")));
  }
  if (!free_field && std::fabs(norm_diff) > 0.1) {
    f.warnings.push_back(fmt::format("fitted Earth field {:.1f} uT is {:+.1f} % from WMM's {:.1f} uT: a gain error, a local "
                                     "anomaly or a wrong place/date",
                                     f.radius_uT, 100 * norm_diff, wmm_norm));
  }
  if (!pf.flight_only) f.warnings.push_back(pf.windows_note);
  if (pf.tilted > 0) f.warnings.push_back(fmt::format("{} sample(s) tilted beyond the windows' limit left out", pf.tilted));
  if (fit->outliers > 0) f.warnings.push_back(fmt::format("{} sample(s) with outlying residuals left out", fit->outliers));
  f.accepted = f.fitness_uT <= kMaxFitness_uT && plausibility::IsPlausible("compass_offset", f.offset_uT.norm());
  if (!f.accepted) {
    f.warnings.push_back(fmt::format("acceptance gate: fitness {:.2f} uT above {:.1f} uT (ArduPilot's relaxed "
                                     "COMPASS_CAL_FIT, 32 mG) or offset out of range",
                                     f.fitness_uT, kMaxFitness_uT));
  }
  if (!throttle) {
    out.compensator = std::make_unique<CurrentSlopeCompensator>("flight", Minv, f.offset_uT, d, 0.0, CurrentFrame::kCorrected);
  } else {
    // calib.yaml's compensator is current-based: a throttle term goes to the parameter files only.
    out.compensator =
        std::make_unique<CurrentSlopeCompensator>("flight", Minv, f.offset_uT, Vector3d::Zero(), 0.0, CurrentFrame::kCorrected);
  }

  // Parameters: the autopilot's own soft iron is kept; the disturbance term as its compensation, the
  // log's own COMPASS_MOTCT / COMPASS_MOT* kept, replaced or zeroed (and the files say which).
  out.params_keep_soft_iron = true;
  out.params_A = fc.soft_iron_in_force;
  const MotorParams mp = CompensationParams(rq.compass_index, rq.px4_index, fit->term_fitted, fo.term_applied, throttle,
                                            fit->term_uT, fit->term_ci_half_uT, Minv, fc.motor_compensation,
                                            fc.px4_comp_type, fc.px4_comp_G, pf.ground_run_note);
  out.ardupilot_extra = mp.ardupilot;
  out.px4_extra = mp.px4;
  fo.motor_params_note = mp.comment;
  out.param_comments.push_back(mp.comment);
  if (fo.term_applied && mp.px4.empty()) {
    f.warnings.emplace_back("PX4: another compensation form (CAL_MAG_COMP_TYP) is in force; the compensation is not written "
                            "for PX4");
  }
  cur["parameters"] = mp.action;
  nlohmann::json& r = out.report;
  r["accepted"] = f.accepted;
  r["gate"] = {{"accepted", f.accepted},
               {"criteria", {{{"name", "fitness_uT"}, {"value", f.fitness_uT}, {"max", kMaxFitness_uT}}}},
               {"failures", f.accepted ? "" : fmt::format("fitness_uT = {:.3f} above max {:.1f}", f.fitness_uT, kMaxFitness_uT)}};
  r["fits"] = nlohmann::json::array();
  r["diagnostics"] = nlohmann::json::object();
  r["coverage"] = {{"fraction", nullptr}, {"planes", 0}};
  r["flight_fit"] = {{"samples_used", fit->samples_used},
                     {"outliers", fit->outliers},
                     {"tilted_left_out", pf.tilted},
                     {"outside_flight_windows", pf.outside},
                     {"windows", pf.windows_note},
                     {"timing", pf.timing_note},
                     {"interval_method", kFlightIntervalMethod},
                     {"current_shift_s", pf.current_shift_s},
                     {"current_shift_range_s", {pf.current_shift_range_s[0], pf.current_shift_range_s[1]}},
                     {"blocks", fit->blocks},
                     {"block_s", pf.options.block_s},
                     {"residual_rms_before_uT", fit->rms_prior_uT},
                     {"residual_rms_after_uT", fit->rms_after_uT},
                     {"offset_ci95_half_uT", Vec(Minv * fit->offset_ci_half_uT)},
                     {"earth_field_N_uT", Vec(fit->field_N_uT)},
                     {"earth_field_ci95_half_uT", Vec(fit->field_ci_half_uT)},
                     {"wmm_field_N_uT", Vec(*prior)},
                     {"field_norm_vs_wmm", norm_diff},
                     {"current", cur}};
  fo.field_norm_vs_wmm = norm_diff;
  out.flight = std::move(fo);
  out.exit_code = f.accepted ? 0 : 1;
  return out;
}

}  // namespace hexsim::magnetics
