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

// Samples with |roll| or |pitch| beyond this are left out: a flip or a vehicle lying on its side
// after a crash, where the logged attitude is least trustworthy (the realdata windows' 60° rule).
constexpr double kMaxTiltDeg = 60.0;
// ArduPilot's most relaxed onboard-calibration fitness (COMPASS_CAL_FIT 32 mG, "relaxed"): the RMS
// of |calibrated| − |field|. Beyond it the fit is reported but rejected (exit 1).
constexpr double kMaxFitness_uT = 3.2;

Result<Vector3d> PriorField(const FlightContext& fc) {
  auto f = EvaluateWmm(fc.where, fc.decimal_year, /*allow_extrapolation=*/true);
  if (!f.ok()) return f.status();
  return f->B_N_uT;
}

}  // namespace

bool UsesFlightPath(const std::vector<MagSample>& samples, const CalibrateRequest& rq) {
  return rq.flight.has_attitude && rq.flight.has_place && rq.flight.t_s.size() == samples.size() &&
         !HasTurntableColumns(samples);
}

Result<CalibrateOutcome> FlightPath(CalibrateOutcome out, const std::vector<MagSample>& samples, const CalibrateRequest& rq) {
  const FlightContext& fc = rq.flight;
  if (!fc.has_attitude || fc.t_s.size() != samples.size()) {
    return Status::BadInput("--method flight: the input has no attitude (it needs a flight log: FlightLog CSV, .bin or .ulg)");
  }
  if (!fc.has_place) {
    return Status::BadInput("--method flight: the log has no place and date for the Earth field (no GPS fix in its meta)");
  }
  auto prior = PriorField(fc);
  if (!prior.ok()) return prior.status();
  const Matrix3d M = fc.body_from_raw;
  if (!(std::fabs(M.determinant()) > 1e-6)) return Status::BadInput("--method flight: the log's compass matrix is singular");
  const double cos_max_tilt = std::cos(kMaxTiltDeg * M_PI / 180.0);
  FlightFitOptions fo = rq.flight_fit;
  fo.prior_field_N_uT = *prior;
  // Flight samples only, when the windows are known and hold enough of them.
  bool flight_only = fc.in_flight.size() == samples.size() &&
                     std::count(fc.in_flight.begin(), fc.in_flight.end(), 1) >= static_cast<std::ptrdiff_t>(fo.min_samples);
  std::string window_note = fc.in_flight.size() != samples.size()
                                ? "no flight windows known: every sample used"
                                : flight_only ? "flight windows only (" + fc.windows_note + ")"
                                              : "too few flight samples: ground samples used too (" + fc.windows_note + ")";
  std::vector<FlightFitSample> fs;
  std::vector<size_t> index;
  int tilted = 0, outside = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    if (flight_only && fc.in_flight[i] == 0) {
      ++outside;
      continue;
    }
    const Matrix3d R = samples[i].q_NB.normalized().toRotationMatrix();
    if (R(2, 2) < cos_max_tilt) {  // body z against down: cos(tilt)
      ++tilted;
      continue;
    }
    FlightFitSample s;
    s.y_uT = M * out.raw_uT[i];
    s.R_NB = R;
    s.current_A = fc.has_current ? samples[i].current_A : std::nan("");
    s.t_s = fc.t_s[i];
    fs.push_back(s);
    index.push_back(i);
  }
  auto fit = FitFlightCompass(fs, fo);
  if (!fit.ok()) return fit.status();

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

  // The current term is applied only when it is resolved (interval excludes 0) and plausible.
  Vector3d d = fit->current_uT_per_A;
  const bool current_resolved = fit->current_fitted && fit->current_resolved;
  const bool current_plausible = plausibility::IsPlausible("current_hard_iron", fit->current_norm_uT_per_A);
  nlohmann::json cur = {{"fitted", fit->current_fitted},
                        {"current_span_A", fit->current_span_A},
                        {"uT_per_A", Vec(d)},
                        {"ci95_half_uT_per_A", Vec(fit->current_ci_half_uT_per_A)},
                        {"norm_mG_per_A", 10 * fit->current_norm_uT_per_A},
                        {"norm_ci95_mG_per_A", {10 * fit->current_norm_ci95[0], 10 * fit->current_norm_ci95[1]}},
                        {"physical_range", plausibility::RangeText("current_hard_iron")},
                        {"plausible", current_plausible},
                        {"resolved", current_resolved},
                        {"max_abs_t", fit->current_max_abs_t},
                        {"t_threshold", fit->current_t_threshold},
                        {"note", fit->current_note}};
  if (!fit->current_fitted) {
    f.warnings.push_back("current compensation not fitted: " + fit->current_note);
    d.setZero();
  } else if (!current_plausible) {
    f.warnings.push_back(fmt::format("current field {:.1f} mG/A outside its physical range ({}): model mismatch, not applied",
                                     10 * fit->current_norm_uT_per_A, plausibility::RangeText("current_hard_iron")));
    d.setZero();
  } else if (!current_resolved) {
    f.warnings.push_back(fmt::format("current field {:.1f} mG/A [{:.1f}, {:.1f}]: not resolved from zero (largest |t| {:.1f} < "
                                     "{:.1f}), not applied",
                                     10 * fit->current_norm_uT_per_A, 10 * fit->current_norm_ci95[0],
                                     10 * fit->current_norm_ci95[1], fit->current_max_abs_t, fit->current_t_threshold));
    d.setZero();
  }
  cur["applied"] = !d.isZero();
  std::vector<Vector3d> after;
  double ss = 0.0;
  int n = 0;
  for (size_t k = 0; k < index.size(); ++k) {
    const Vector3d c = f.Correct(out.raw_uT[index[k]]) - d * (fc.has_current ? fs[k].current_A : 0.0);
    after.push_back(c);
    const double e = c.norm() - f.radius_uT;
    ss += e * e;
    ++n;
  }
  f.norm_spread_after = NormSpread(after);
  f.fitness_uT = n > 0 ? std::sqrt(ss / n) : 0.0;
  const double wmm_norm = prior->norm();
  const double norm_diff = f.radius_uT / wmm_norm - 1.0;
  if (!plausibility::IsPlausible("compass_offset", f.offset_uT.norm())) {
    f.warnings.push_back(fmt::format("offset {:.1f} uT outside {}: model mismatch", f.offset_uT.norm(),
                                     plausibility::RangeText("compass_offset")));
  }
  if (std::fabs(norm_diff) > 0.1) {
    f.warnings.push_back(fmt::format("fitted Earth field {:.1f} uT is {:+.1f} % from WMM's {:.1f} uT: a gain error, a local "
                                     "anomaly or a wrong place/date",
                                     f.radius_uT, 100 * norm_diff, wmm_norm));
  }
  if (!flight_only) f.warnings.push_back(window_note);
  if (tilted > 0) f.warnings.push_back(fmt::format("{} sample(s) tilted beyond {:.0f} deg left out", tilted, kMaxTiltDeg));
  if (fit->outliers > 0) f.warnings.push_back(fmt::format("{} sample(s) with outlying residuals left out", fit->outliers));
  f.accepted = f.fitness_uT <= kMaxFitness_uT && plausibility::IsPlausible("compass_offset", f.offset_uT.norm());
  if (!f.accepted) {
    f.warnings.push_back(fmt::format("acceptance gate: fitness {:.2f} uT above {:.1f} uT (ArduPilot's relaxed "
                                     "COMPASS_CAL_FIT, 32 mG) or offset out of range",
                                     f.fitness_uT, kMaxFitness_uT));
  }
  out.compensator = std::make_unique<CurrentSlopeCompensator>("flight", Minv, f.offset_uT, d, 0.0, CurrentFrame::kCorrected);

  // Parameters: the autopilot's own soft iron is kept; the current field as its compensation.
  out.params_keep_soft_iron = true;
  out.params_A = fc.soft_iron_in_force;
  const int ai = rq.compass_index;
  if (!d.isZero()) {
    const std::string mot = ai == 0 ? "COMPASS_MOT_" : fmt::format("COMPASS_MOT{}_", ai + 1);
    out.ardupilot_extra.emplace_back("COMPASS_MOTCT", 2.0);  // 2: current-based
    const Vector3d mot_mG = -10.0 * d;                          // corrected = M(raw + OFS) + MOT·I
    for (int k = 0; k < 3; ++k) out.ardupilot_extra.emplace_back(mot + static_cast<char>('X' + k), mot_mG(k));
    if (fc.px4_comp_type == 1) {
      f.warnings.emplace_back("PX4: the log's throttle-based compensation (CAL_MAG_COMP_TYP 1) is in force; the current "
                           "compensation is not written for PX4");
    } else {
      // PX4: S·((u + P·comp) − off) with P = I/1000 (kA), comp in G/kA: R_s·S·P·Δcomp = −d·I.
      const Vector3d delta_G_per_kA = -10.0 * Minv * d;
      const Vector3d comp = (fc.px4_comp_type == 2 ? fc.px4_comp_G : Vector3d::Zero()) + delta_G_per_kA;
      const int pi = rq.px4_index >= 0 ? rq.px4_index : ai;
      out.px4_extra.emplace_back("CAL_MAG_COMP_TYP", 2.0);
      for (int k = 0; k < 3; ++k) {
        out.px4_extra.emplace_back(fmt::format("CAL_MAG{}_{}COMP", pi, static_cast<char>('X' + k)), comp(k));
      }
    }
  }
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
                     {"tilted_left_out", tilted},
                     {"outside_flight_windows", outside},
                     {"windows", window_note},
                     {"blocks", fit->blocks},
                     {"block_s", fo.block_s},
                     {"residual_rms_before_uT", fit->rms_prior_uT},
                     {"residual_rms_after_uT", fit->rms_after_uT},
                     {"offset_ci95_half_uT", Vec(Minv * fit->offset_ci_half_uT)},
                     {"earth_field_N_uT", Vec(fit->field_N_uT)},
                     {"earth_field_ci95_half_uT", Vec(fit->field_ci_half_uT)},
                     {"wmm_field_N_uT", Vec(*prior)},
                     {"field_norm_vs_wmm", norm_diff},
                     {"current", cur}};
  out.exit_code = f.accepted ? 0 : 1;
  return out;
}

}  // namespace hexsim::magnetics
