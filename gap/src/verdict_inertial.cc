// Verdicts of the inertial and dynamics channels (gyro, accel, dynamics), the same decomposition as
// the compasses' (private to gap/). Baseline: the configured model's prediction with the sensor's
// constant bias removed where the configured sensor has one (Analyzer). Noise floor: the
// first-difference variance of that residual (gyro, accel), or, for the dynamics channel whose
// effects are phase-confined and slow, its variance above ~4 Hz (HighPassVariance, 0.25 s window).
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
std::string SeparatingManoeuvre(Effect a, Effect b) {
  using E = Effect;
  auto is = [&](Effect x, Effect y) { return (a == x && b == y) || (a == y && b == x); };
  if (is(E::kCurrentHardIron, E::kThrottleHardIron))
    return "hold one throttle while the current changes (a long hover as the battery sags, or a payload change): "
           "current-driven field follows the current, throttle-driven does not";
  if (is(E::kCurrentHardIron, E::kCurrentSoftIron))
    return "a slow 360 deg yaw turn at constant high current: a soft-iron change varies with heading, a hard iron does not";
  if (is(E::kHardIronOffset, E::kLocalAnomaly))
    return "yaw turns and large pitch/roll, or the same pattern at another site: an anomaly is fixed in NED, a hard iron in the body";
  if (is(E::kBatterySag, E::kThrustScale))
    return "climbs and descents over a wide throttle range, or a long hover as the battery drains: a voltage sag grows "
           "with current x dT/dV (faster than the thrust), a k_T or mass error stays proportional to the thrust";
  if (is(E::kWind, E::kRotorDrag))
    return "hover facing several headings and fly the same legs both ways: wind drag is fixed in NED, rotor drag "
           "follows the air speed and the rotor speed";
  if (is(E::kReferenceYaw, E::kCurrentHardIron) || is(E::kReferenceYaw, E::kThrottleHardIron) ||
      is(E::kReferenceYaw, E::kPerMotorCurrentHardIron))
    return "a slow 360 deg yaw turn at a steady high current: the reference's heading error turns the Earth field in "
           "NED, so its field turns in the body with the heading; a current field at the compass stays fixed in the body";
  if (is(E::kLatency, E::kCurrentLag))
    return "fast yaw turns at constant throttle (latency shows) against throttle steps at constant attitude (current lag shows)";
  if (is(E::kMisalignment, E::kLocalAnomaly) || is(E::kMisalignment, E::kHardIronOffset) || is(E::kMisalignment, E::kScaleError))
    return "rotate through all attitudes (full yaw turns and large pitch/roll)";
  return std::string("a manoeuvre that varies the regressor of '") + Info(a).name + "' while holding that of '" + Info(b).name +
         "' fixed";
}


namespace {

// The decision on the fitted families (CONTRACTS.md "The verdict is a decomposition"): a gap when
// the residual stands above its floor and some plausible family is significant and material; the
// model grown from the one-standard-error choice; its effects by explained share.
void Decide(const Analyzer& an, double noise_var, const DiagnoseOptions& o, Attribution* at, ChannelResult* res) {
  const size_t F = at->fam_names.size();
  const double cv0 = an.base_sse();
  const double ms_before = MeanSquare(an.y());
  res->noise_floor_ratio = noise_var > 0 ? ms_before / noise_var : 0.0;
  const bool above_floor = res->noise_floor_ratio > 1.0 + o.floor_margin_z / std::sqrt(std::max(1.0, an.total_n()));
  std::vector<bool> material(F, false);
  double p_cand = 1.0;
  for (size_t f = 0; f < F; ++f) {
    const Evaluated& e = at->all[at->fam_best[f]];
    CandidateResult& r = at->results[f];
    r.p_value = std::min(1.0, e.wald_p * at->fam_tests[f] * static_cast<double>(F));
    material[f] = r.explained_share >= o.min_effect_share && IsMaterial(an, e, cv0, noise_var, o);
    if (material[f]) p_cand = std::min(p_cand, r.p_value);
  }
  double p_lb = 1.0;
  constexpr int kLjungBoxLags = 20;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> x;
    for (const auto& v : an.y()) x.push_back(v[axis]);
    p_lb = std::min(p_lb, 3.0 * internal::LjungBoxP(x, kLjungBoxLags));
  }
  res->ljung_box_p = std::min(1.0, p_lb);
  res->p_value = p_cand;
  res->gap_detected = res->p_value < o.alpha && above_floor;
  std::vector<bool> eligible = Eligible(*at, o);
  for (size_t f = 0; f < F; ++f) eligible[f] = eligible[f] && material[f];
  const size_t first = res->gap_detected ? ChooseFirst(*at, eligible) : F;
  res->residual_after = an.y();
  std::vector<CandidateResult> all = at->results;
  if (!res->gap_detected) {
    res->verdict = "none";
    res->explanation = F == 0 ? "no candidate effect could be formed for this channel"
                       : p_cand < o.alpha
                           ? fmt::format("a candidate is significant, but the residual is only {:.1f} % above its noise "
                                         "floor: no material gap",
                                         100 * (res->noise_floor_ratio - 1))
                           : "residual is consistent with the configured noise: no significant, material effect";
  } else if (first == F) {
    res->verdict = "unexplained";
    res->explanation = "every significant, material candidate's fit is outside its physical range: model mismatch";
    for (const CandidateResult& k : all) {
      if (!k.plausible && k.p_value <= o.alpha && k.explained_share >= o.min_effect_share) res->findings.push_back(RefusedFinding(k, false));
    }
  } else {
    const ModelChoice choice = ChooseModel(an, *at, first, eligible, noise_var, o);
    const SelectedModel& m = choice.m;
    for (size_t f : m.fams) {
      all[f].selected = true;
      res->effects.push_back(ToEffect(all[f], all[f].explained_share, "fit"));
    }
    SortEffects(&res->effects);
    res->residual_after = an.After(m.eval);
    res->heldout_shrink = Shrink(m.eval.cv_sse, cv0);
    res->explained_share = ExplainedShare(cv0, m.eval.cv_sse, noise_var * an.total_n());
    res->chosen_regressor_name = m.joint->regressor_name;
    res->chosen_regressor = at->all[at->fam_best[m.fams.front()]].cand->regressor;
    if (!choice.tie.empty()) res->findings.push_back(choice.tie);
    if (choice.ambiguous) {
      res->verdict = "ambiguous";
      res->explanation = TieUndecided(*at, first, choice.rival);
    } else {
      res->verdict = res->effects.front().effect;
      res->partial = res->effects.front().explained_share < o.headline_share;
    }
  }
  res->candidates = OrderCandidates(res->effects, std::move(all));
}

// The vehicle file must hold this aircraft up. thrust_scale is the factor that matches the
// configured thrust at the logged motor outputs to the measured specific force; its physical range
// (plausibility table: 0.5..2, a thrust coefficient or mass within a factor of two) bounds every
// error the vehicle file can carry and still describe the airframe. When its whole 95 % interval
// lies outside that range, the replay predicts another aircraft (another frame, motors, propellers
// or mass): every library effect fitted against that residual describes the mismatch, not the
// aircraft, so none is reported (a battery sag of 0.15 Ω fitted on such a log explains part of it).
void StateVehicleMismatch(ChannelResult* res) {
  if (!res->gap_detected) return;
  const auto ts = std::find_if(res->candidates.begin(), res->candidates.end(),
                               [](const CandidateResult& k) { return k.id == Effect::kThrustScale; });
  if (ts == res->candidates.end() ||
      plausibility::IntervalPlausible(ts->effect, ts->magnitude_ci95[0], ts->magnitude_ci95[1])) {
    return;
  }
  const plausibility::PhysicalRange* range = plausibility::FindRange(ts->effect);
  if (!range) return;
  res->verdict = "unexplained";
  res->partial = false;
  res->effects.clear();
  for (CandidateResult& k : res->candidates) k.selected = false;
  res->explained_share = 0.0;
  res->heldout_shrink = 0.0;
  res->residual_after = res->residual_before;
  res->chosen_regressor.clear();
  res->chosen_regressor_name.clear();
  res->explanation = fmt::format(
      "model mismatch: the vehicle file does not describe this aircraft: its thrust at the logged motor outputs must "
      "be scaled by {:.3g} [{:.3g}, {:.3g}] to match the accelerometer, outside thrust_scale's physical range {:.3g}..{:.3g} "
      "(a thrust coefficient or mass within a factor of two); no dynamics effect is reported: give the vehicle "
      "file of this airframe (frame, motors, propellers, mass)",
      ts->magnitude, ts->magnitude_ci95[0], ts->magnitude_ci95[1], range->lo, range->hi);
}

// The dynamics channel's floor against the accelerometer's own fast variance
// (DiagnoseOptions::max_floor_over_measured). Beyond it the floor is the replay's error: a "none"
// becomes "unexplained" (the residual's floor is not noise, so no gap cannot be told), and a selected
// effect keeps its place with the floor said beside it (its share is measured above that floor).
void StateFloorMismatch(const DiagnoseOptions& o, ChannelResult* res) {
  if (!(res->measured_floor_rms > 0.0)) return;
  const double ratio = (res->noise_rms * res->noise_rms) / (res->measured_floor_rms * res->measured_floor_rms);
  if (!(ratio > o.max_floor_over_measured)) return;
  const std::string what = fmt::format(
      "model mismatch: the residual's floor above 4 Hz is {:.3g} {} RMS, {:.1f} times the variance the accelerometer "
      "itself shows there ({:.3g} {} RMS; a right replay adds nothing there, limit {:.3g} times): the configured "
      "vehicle's fast response (thrust from the logged outputs: motors, propellers, mass) or the accelerometer's "
      "filtering differs from this aircraft's",
      res->noise_rms, res->unit, ratio, res->measured_floor_rms, res->unit, o.max_floor_over_measured);
  if (res->gap_detected) {
    res->findings.push_back(what);
    return;
  }
  res->gap_detected = true;
  res->verdict = "unexplained";
  res->partial = false;
  res->explanation = what + "; no effect is judged against that floor";
}

// What the log's row rate leaves undetermined, added to each candidate's interval. The replay
// reconstructs its inputs between rows (an autopilot commands its motors several times per logged
// row: the commands in between are not in the log), and that reconstruction's error moves a fit
// whose interval is far tighter than it (a motor time constant 1-3 % off at 100 Hz rows, unbiased
// at 1 kHz). The same fit to the residual replayed from every other row's inputs moves by Δ_p
// (phase p: even or odd rows kept); each Δ_p is one realisation of the reconstruction's error at
// twice the row interval, which is not smaller than the error at the log's own: the RMS of the two,
// measured per log, is added in quadrature to the statistical half-widths. A candidate whose
// regressors the replay builds is refitted as rebuilt from the half-rate replay (ChannelData::half_rate).
// Beside it, the configured sensor's bias random walk (BiasWalkCov: its 95 % half-width, 1.96 σ),
// also in quadrature: the jackknife sees the walk's part inside each block, not its carry-over
// from block to block (so the two overlap somewhat: the sum errs wide).
void AddSystematicTerms(const ChannelData& ch, const DiagnoseOptions& o, Attribution* at) {
  std::vector<Analyzer> halves;
  std::vector<ChannelData> half_data(ch.half_rate.size());
  bool half_ok = true;
  for (size_t p = 0; p < ch.half_rate.size(); ++p) {
    half_ok = half_ok && ch.half_rate[p].y.size() == ch.t.size();
    half_data[p].t = ch.t;
    half_data[p].y = ch.half_rate[p].y;
    half_data[p].bias_nuisance = ch.bias_nuisance;
  }
  if (!half_ok) half_data.clear();
  halves.reserve(half_data.size());
  for (const ChannelData& h : half_data) halves.emplace_back(h, o);
  if (halves.empty() && !(ch.bias_walk_per_sqrt_s > 0)) return;
  // [lo, hi] about mid, widened by delta in quadrature on each side.
  auto widen = [](double delta, double mid, double* lo, double* hi) {
    const double below = mid - *lo, above = *hi - mid;
    *lo = mid - std::sqrt(below * below + delta * delta);
    *hi = mid + std::sqrt(above * above + delta * delta);
  };
  constexpr double kZ95 = 1.959964;
  for (size_t f = 0; f < at->results.size(); ++f) {
    const Evaluated& e = at->all[at->fam_best[f]];
    const Candidate& c = *e.cand;
    if (!c.grid_name.empty() || !e.full.ok) continue;  // profiled (grid) parameters keep their grid intervals
    const size_t p = static_cast<size_t>(c.p());
    // Squared half-widths per parameter (physical units) and of the magnitude.
    std::vector<double> d_param(p, 0.0);
    double d_mag = 0.0;
    bool ok = true;
    for (size_t h_i = 0; h_i < halves.size() && ok; ++h_i) {
      // The candidate as rebuilt from the half-rate replay (the same parameters), else its own.
      const auto& rebuilt = ch.half_rate[h_i].candidates;
      const auto same = std::find_if(rebuilt.begin(), rebuilt.end(), [&](const Candidate& r) {
        return r.effect == c.effect && r.names == c.names && r.X.size() == c.X.size();
      });
      const Evaluated h = halves[h_i].FitOnly(same != rebuilt.end() ? *same : c);
      ok = h.full.ok;
      if (!ok) break;
      for (size_t j = 0; j < p; ++j) {
        const double d = (h.full.beta[h.off + static_cast<int>(j)] - e.full.beta[e.off + static_cast<int>(j)]) * c.scale[j];
        d_param[j] += d * d / static_cast<double>(halves.size());
      }
      const double d = MagnitudeOf(h) - MagnitudeOf(e);
      d_mag += d * d / static_cast<double>(halves.size());
    }
    if (!ok) {  // a half-rate refit failed: no row-rate term
      std::fill(d_param.begin(), d_param.end(), 0.0);
      d_mag = 0.0;
    }
    if (const Eigen::MatrixXd W = BiasWalkCov(ch, c); W.rows() == static_cast<int>(p)) {
      // Physical units; the magnitude by the delta method (a norm: along the fitted direction).
      Eigen::VectorXd s(static_cast<int>(p)), g = Eigen::VectorXd::Zero(static_cast<int>(p));
      for (size_t j = 0; j < p; ++j) s[static_cast<int>(j)] = c.scale[j];
      const Eigen::MatrixXd Ws = s.asDiagonal() * W * s.asDiagonal();
      for (size_t j = 0; j < p; ++j) d_param[j] += kZ95 * kZ95 * Ws(static_cast<int>(j), static_cast<int>(j));
      const int pm = c.magnitude_params > 0 ? c.magnitude_params : c.p();
      const Eigen::VectorXd v = (e.full.beta.segment(e.off, pm).array() * s.head(pm).array()).matrix();
      if (pm == 1) g[0] = 1.0;
      else if (v.norm() > 0) g.head(pm) = v / v.norm();
      d_mag += kZ95 * kZ95 * g.dot(Ws * g);
    }
    CandidateResult& r = at->results[f];
    for (size_t j = 0; j < p; ++j) {
      const auto it = r.ci95.find(c.names[j]);
      if (it == r.ci95.end()) continue;
      widen(std::sqrt(d_param[j]), e.full.beta[e.off + static_cast<int>(j)] * c.scale[j], &it->second.lo, &it->second.hi);
    }
    widen(std::sqrt(d_mag), r.magnitude, &r.magnitude_ci95[0], &r.magnitude_ci95[1]);
    // A norm (several parameters) is never negative.
    if ((c.magnitude_params > 0 ? c.magnitude_params : c.p()) > 1) r.magnitude_ci95[0] = std::max(0.0, r.magnitude_ci95[0]);
  }
}

}  // namespace

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
  const double noise_var = floor_variance(an.y());
  res.noise_rms = std::sqrt(noise_var);
  if (!ch.measured.empty()) res.measured_floor_rms = std::sqrt(floor_variance(ch.measured));
  const double noise_sse = noise_var * an.total_n();
  Attribution at = Attribute(ch, an, o, rng, noise_sse);
  AddSystematicTerms(ch, o, &at);
  for (CandidateResult& r : at.results) {
    if (r.id == Effect::kLatency && ch.known_hold_max_s > 0) {
      // Report the total latency: the known sample hold removed in the replay plus the excess.
      r.magnitude += ch.known_hold_s;
      r.magnitude_ci95[0] += ch.known_hold_s;
      r.magnitude_ci95[1] += ch.known_hold_s;
      r.params["latency_s"] = r.magnitude;
      r.ci95["latency_s"] = {r.magnitude_ci95[0], r.magnitude_ci95[1]};
      r.params["known_sample_hold_s"] = ch.known_hold_s;
    }
    if (r.id == Effect::kGroundEffect) {
      // The linear parameter is a = R²; report the effective radius R (monotone: interval maps).
      const double a = r.params.count("radius_sq_m2") ? r.params.at("radius_sq_m2") : 0.0;
      r.magnitude = std::sqrt(std::max(0.0, a));
      r.magnitude_ci95[0] = std::sqrt(std::max(0.0, r.magnitude_ci95[0]));
      r.magnitude_ci95[1] = std::sqrt(std::max(0.0, r.magnitude_ci95[1]));
      r.magnitude_unit = "m";
      r.params["radius_m"] = r.magnitude;
      r.ci95["radius_m"] = {r.magnitude_ci95[0], r.magnitude_ci95[1]};
    }
    if (r.id == Effect::kThrustScale) {
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
  Decide(an, noise_var, o, &at, &res);
  StateFloorMismatch(o, &res);
  StateVehicleMismatch(&res);
  res.where = Locate(ch, an.y(), log, phases);
  if (res.gap_detected) {
    res.residual_left = DescribeLeft(ch.t, res.residual_after, 1.0 - std::max(0.0, res.explained_share),
                                     Locate(ch, res.residual_after, log, phases));
  }
  return res;
}

}  // namespace hexsim::gap::internal
