// Verdicts of the inertial and dynamics channels (gyro, accel, dynamics): a significant candidate that
// removes half the held-out mean square, with the adequacy check on what is left (private to gap/).
#include <algorithm>
#include <cmath>
#include <map>

#include <fmt/format.h>

#include "attribution.h"
#include "detection.h"
#include "hexsim/common/plausibility.h"
#include "stats.h"
#include "verdict.h"

namespace hexsim::gap::internal {

// Which manoeuvre separates two collinear candidates.
std::string SeparatingManoeuvre(const std::string& a, const std::string& b) {
  auto is = [&](const char* x, const char* y) { return (a == x && b == y) || (a == y && b == x); };
  if (is("current_hard_iron", "throttle_hard_iron"))
    return "hold one throttle while the current changes (a long hover as the battery sags, or a payload change): "
           "current-driven field follows the current, throttle-driven does not";
  if (is("current_hard_iron", "current_soft_iron"))
    return "a slow 360 deg yaw turn at constant high current: a soft-iron change varies with heading, a hard iron does not";
  if (is("hard_iron_offset", "local_anomaly"))
    return "yaw turns and large pitch/roll, or the same pattern at another site: an anomaly is fixed in NED, a hard iron in the body";
  if (is("battery_sag", "thrust_scale"))
    return "climbs and descents over a wide throttle range, or a long hover as the battery drains: a voltage sag grows "
           "with current x dT/dV (faster than the thrust), a k_T or mass error stays proportional to the thrust";
  if (is("wind", "rotor_drag"))
    return "hover facing several headings and fly the same legs both ways: wind drag is fixed in NED, rotor drag "
           "follows the air speed and the rotor speed";
  if (is("latency", "current_lag"))
    return "fast yaw turns at constant throttle (latency shows) against throttle steps at constant attitude (current lag shows)";
  if (is("misalignment", "local_anomaly") || is("misalignment", "hard_iron_offset") || is("misalignment", "scale_error"))
    return "rotate through all attitudes (full yaw turns and large pitch/roll)";
  return "a manoeuvre that varies the regressor of '" + a + "' while holding that of '" + b + "' fixed";
}


ChannelResult AnalyzeInertial(const ChannelData& ch, const logs::FlightLog& log, const std::vector<std::string>& phases,
                      const DiagnoseOptions& o, RngStream* rng) {
  ChannelResult res;
  res.channel = ch.name;
  res.unit = ch.unit;
  res.samples = static_cast<int>(ch.t.size());
  res.not_available = ch.not_available;
  Analyzer an(ch, o);
  res.rms_before = std::sqrt(MeanSquare(ch.y));
  res.t_s = ch.t;
  res.residual_before = an.y();
  // Channels whose effects are phase-confined and low-frequency (dynamics) take their floor from
  // the residual above ~4 Hz, which holds the replay's own unresolvable part.
  constexpr double kFloorWindow_s = 0.25;
  auto floor_variance = [&](const std::vector<Vec3>& e) {
    return ch.explain_above_noise ? HighPassVariance(ch.t, e, kFloorWindow_s) : NoiseVariance(ch.t, e);
  };
  res.noise_rms = std::sqrt(floor_variance(an.y()));

  Attribution at = Attribute(ch, an, o, rng);
  const std::vector<Evaluated>& all = at.all;
  const std::vector<std::string>& fam_names = at.fam_names;
  const std::vector<size_t>& fam_best = at.fam_best;
  std::map<std::string, std::vector<size_t>>& family = at.family;
  const size_t F = fam_names.size();
  const int G = an.G();
  res.candidates = at.results;
  for (CandidateResult& r : res.candidates) {
    if (r.effect == "latency" && ch.known_hold_max_s > 0) {
      // Report the total latency: the known sample hold removed in the replay plus the excess.
      r.magnitude += ch.known_hold_s;
      r.magnitude_ci95[0] += ch.known_hold_s;
      r.magnitude_ci95[1] += ch.known_hold_s;
      r.params["latency_s"] = r.magnitude;
      r.ci95["latency_s"] = {r.magnitude_ci95[0], r.magnitude_ci95[1]};
      r.params["known_sample_hold_s"] = ch.known_hold_s;
    }
    if (r.effect == "ground_effect") {
      // The linear parameter is a = R²; report the effective radius R (monotone: interval maps).
      const double a = r.params.count("radius_sq_m2") ? r.params.at("radius_sq_m2") : 0.0;
      r.magnitude = std::sqrt(std::max(0.0, a));
      r.magnitude_ci95[0] = std::sqrt(std::max(0.0, r.magnitude_ci95[0]));
      r.magnitude_ci95[1] = std::sqrt(std::max(0.0, r.magnitude_ci95[1]));
      r.magnitude_unit = "m";
      r.params["radius_m"] = r.magnitude;
      r.ci95["radius_m"] = {r.magnitude_ci95[0], r.magnitude_ci95[1]};
    }
    if (r.effect == "thrust_scale") {
      // The linear parameter is s − 1; the table's range (0.5..2) is for the scale s itself.
      r.magnitude += 1.0;
      r.magnitude_ci95[0] += 1.0;
      r.magnitude_ci95[1] += 1.0;
      r.params["thrust_scale"] = r.magnitude;
      r.ci95["thrust_scale"] = {r.magnitude_ci95[0], r.magnitude_ci95[1]};
    }
    r.plausible = plausibility::IsPlausible(r.effect, r.magnitude);
    r.physical_range = plausibility::RangeText(r.effect);
  }
  const std::vector<size_t>& order = at.order;

  // Is there a gap at all? A gap exists when some physical candidate's parameters are significantly
  // non-zero by the cluster-robust Wald test (Bonferroni over the families, and over the grid of a
  // profiled family), that candidate also lowers the held-out residual, and the residual exceeds
  // the high-frequency noise floor. The residual's whiteness (Ljung–Box) is reported, not used: the
  // configured models leave a coloured but unstructured residual (the current is logged at the row
  // rate, the compass samples between rows), which is part of the noise floor a real log has too.
  const double noise_var = floor_variance(an.y());
  const double ms_before = MeanSquare(an.y());
  res.noise_floor_ratio = noise_var > 0 ? ms_before / noise_var : 0.0;
  const double floor_margin = 1.0 + 6.0 / std::sqrt(std::max(1.0, an.total_n()));
  const bool above_floor = res.noise_floor_ratio > floor_margin;
  double p_cand = 1.0;
  for (size_t f = 0; f < F; ++f) {
    const Evaluated& e = all[fam_best[f]];
    const double pf = std::min(1.0, e.wald_p * static_cast<double>(family[fam_names[f]].size()));
    res.candidates[f].p_value = pf;
    bool lowers = res.candidates[f].heldout_shrink > 0;
    if (ch.explain_above_noise) {
      // Material: removes at least kMinMaterialShare of the held-out residual above the noise floor
      // (the replay's own unresolvable part, e.g. commands between log rows, is not a gap).
      constexpr double kMinMaterialShare = 0.1;
      const double ms0 = an.base_sse() / an.total_n();
      const double excess = ms0 - noise_var;
      lowers = excess > 0 && (ms0 - e.cv_sse / an.total_n()) / excess >= kMinMaterialShare;
    }
    if (lowers) p_cand = std::min(p_cand, pf * static_cast<double>(F));
  }
  double p_lb = 1.0;
  constexpr int kLjungBoxLags = 20;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> x;
    for (const auto& v : an.y()) x.push_back(v[axis]);
    p_lb = std::min(p_lb, 3.0 * internal::LjungBoxP(x, kLjungBoxLags));
  }
  res.ljung_box_p = std::min(1.0, p_lb);
  res.p_value = std::min(1.0, p_cand);
  res.gap_detected = res.p_value < o.alpha && above_floor;

  std::vector<Vec3> after = an.y();
  // The reported model holds plausible fits only (realdata's table): the best family whose fit is
  // inside its physical range leads; an out-of-range fit stays listed as a model mismatch.
  size_t first_plausible = F;
  for (size_t idx = 0; idx < F && first_plausible == F; ++idx) {
    if (res.candidates[order[idx]].plausible) first_plausible = idx;
  }
  if (res.gap_detected && F > 0 && first_plausible == F) {
    res.verdict = "unexplained";
    res.explanation = fmt::format("every candidate's fit is outside its physical range (best: {}): model mismatch",
                                  fam_names[order[0]]);
  } else if (!res.gap_detected || F == 0) {
    res.verdict = "none";
    if (F == 0) {
      res.explanation = "no candidate effect could be formed for this channel";
    } else if (res.p_value < o.alpha) {
      res.explanation = fmt::format("a candidate is statistically significant, but the residual is only {:.1f} % above "
                                    "its noise floor: no material gap",
                                    100 * (res.noise_floor_ratio - 1));
    } else {
      res.explanation = "residual is consistent with the configured noise: no significant gap";
    }
  } else {
    const size_t b1 = order[first_plausible];
    const Evaluated& e1 = all[fam_best[b1]];
    Candidate chosen = *e1.cand;
    Evaluated chosen_eval = an.Evaluate(chosen);
    double chosen_cv = e1.cv_sse;
    res.candidates[b1].selected = true;
    std::string second;
    // Forward step: a second effect that significantly improves the held-out fit.
    double best_cv = chosen_cv;
    size_t b2 = F;
    Evaluated joint_best;
    Candidate joint_cand;
    for (size_t idx = 0; idx < F; ++idx) {
      const size_t f = order[idx];
      if (f == b1 || !res.candidates[f].plausible || res.candidates[f].p_value * F > o.alpha) continue;
      Candidate j = Join(*e1.cand, *all[fam_best[f]].cand);
      Evaluated ej = an.Evaluate(j);
      if (!ej.full.ok) continue;
      const double p_partial =
          WaldP(ej.full.beta, ej.cov, Range(e1.cand->p(), j.p()), G) * static_cast<double>(F) *
          static_cast<double>(family[fam_names[f]].size());
      if (p_partial < o.alpha && ej.cv_sse < 0.9 * chosen_cv && ej.cv_sse < best_cv) {
        best_cv = ej.cv_sse;
        b2 = f;
        joint_cand = std::move(j);
        joint_best = ej;
      }
    }
    if (b2 < F) {
      res.candidates[b2].selected = true;
      chosen = joint_cand;
      chosen_eval = an.Evaluate(chosen);
      chosen_cv = best_cv;
      second = fam_names[b2];
    }
    res.heldout_shrink = Shrink(chosen_cv, an.base_sse());
    after = an.After(chosen_eval);
    const double ratio = MeanSquare(after) / std::max(1e-300, NoiseVariance(ch.t, after));
    const std::string top = fam_names[b1];
    res.chosen_regressor_name = e1.cand->regressor_name;
    res.chosen_regressor = e1.cand->regressor;
    // Share of the residual explained: of the whole mean square (1 − (1 − shrink)²), or, for
    // channels whose effects are phase-confined, of the part above the noise floor.
    const double whole_share = 1.0 - (1.0 - res.candidates[b1].heldout_shrink) * (1.0 - res.candidates[b1].heldout_shrink);
    bool explained = whole_share >= o.headline_share;
    if (ch.explain_above_noise) {
      const double ms0 = an.base_sse() / an.total_n();
      const double ms_cv = e1.cv_sse / an.total_n();
      const double excess = ms0 - noise_var;
      explained = excess > 0 && (ms0 - ms_cv) / excess >= o.headline_share;
    }
    if (!explained) {
      res.verdict = "unexplained";
      res.explanation = fmt::format("no candidate removes half the held-out residual mean square{} (best: {}, shrink {:.0f} %)",
                                    ch.explain_above_noise ? " above the noise floor" : "", top,
                                    100 * res.candidates[b1].heldout_shrink);
    } else if (constexpr double kAdequacyRatio = 1.3; !ch.explain_above_noise && ratio > kAdequacyRatio) {
      res.verdict = "unexplained";
      res.explanation = fmt::format("best partial explanation {}{} (held-out shrink {:.0f} %) leaves a structured residual "
                                    "{:.1f}x the noise power: the cause is not in the library in this form",
                                    top, second.empty() ? "" : " + " + second, 100 * res.heldout_shrink, ratio);
    } else {
      res.verdict = top;
      // Ambiguity: the bootstrap cannot separate the best from a rival.
      size_t rival = F;
      for (size_t f = 0; f < F; ++f) {
        if (f != b1 && fam_names[f] != second && res.candidates[f].plausible &&
            (rival == F || res.candidates[f].probability > res.candidates[rival].probability)) {
          rival = f;
        }
      }
      if (rival < F && res.candidates[b1].probability < 0.7 && res.candidates[rival].probability >= 0.2) {
        res.verdict = "ambiguous";
        res.explanation = fmt::format("{} (p={:.2f}) and {} (p={:.2f}) explain the data about equally: {}", top,
                                      res.candidates[b1].probability, fam_names[rival],
                                      res.candidates[rival].probability, SeparatingManoeuvre(top, fam_names[rival]));
      } else {
        res.explanation = second.empty() ? "" : "together with " + second;
      }
    }
  }
  res.residual_after = after;
  res.where = Locate(ch, an.y(), log, phases);
  res.explained_share = 1.0 - (1.0 - res.heldout_shrink) * (1.0 - res.heldout_shrink);
  // Best first: selected, then by held-out shrink.
  std::vector<CandidateResult> sorted;
  for (size_t i : order) {
    if (res.candidates[i].selected) sorted.push_back(res.candidates[i]);
  }
  for (size_t i : order) {
    if (!res.candidates[i].selected) sorted.push_back(res.candidates[i]);
  }
  res.candidates = std::move(sorted);
  return res;
}


}  // namespace hexsim::gap::internal
