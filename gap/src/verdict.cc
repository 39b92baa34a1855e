// The compass verdict in CONTRACTS.md's order (see verdict.h).
#include "verdict.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <fmt/format.h>

#include "detection.h"
#include "hexsim/common/plausibility.h"

namespace hexsim::gap::internal {
namespace {

// Σ_f (a_f − b_f) and its standard error √(F·var(a_f − b_f)) over the CV folds.
struct FoldDiff {
  double sum = 0.0, se = 0.0;
};
FoldDiff Diff(const std::vector<double>& a, const std::vector<double>& b) {
  FoldDiff d;
  const size_t F = std::min(a.size(), b.size());
  if (F < 2) return d;
  double mean = 0;
  for (size_t f = 0; f < F; ++f) mean += a[f] - b[f];
  d.sum = mean;
  mean /= static_cast<double>(F);
  double var = 0;
  for (size_t f = 0; f < F; ++f) var += (a[f] - b[f] - mean) * (a[f] - b[f] - mean);
  d.se = std::sqrt(static_cast<double>(F) * var / static_cast<double>(F - 1));
  return d;
}

// Does a's column space (over the samples) hold b's? Residual of b's Gram matrix on a's below 0.1 %.
bool Nests(const Candidate& a, const Candidate& b) {
  const int pa = a.p(), pb = b.p();
  if (pb > pa || a.X.size() != b.X.size()) return false;
  Eigen::MatrixXd Aaa = Eigen::MatrixXd::Zero(pa, pa), Aab = Eigen::MatrixXd::Zero(pa, pb), Abb = Eigen::MatrixXd::Zero(pb, pb);
  for (size_t k = 0; k < a.X.size(); ++k) {
    Aaa.noalias() += a.X[k].transpose() * a.X[k];
    Aab.noalias() += a.X[k].transpose() * b.X[k];
    Abb.noalias() += b.X[k].transpose() * b.X[k];
  }
  const double tr = Abb.trace();
  if (!(tr > 0)) return true;
  const Eigen::MatrixXd reg = Aaa + Eigen::MatrixXd::Identity(pa, pa) * 1e-12 * Aaa.trace();
  const Eigen::MatrixXd left = Abb - Aab.transpose() * reg.ldlt().solve(Aab);
  return left.trace() < 1e-3 * tr;
}

std::string Percent(double x) { return fmt::format("{:.0f} %", 100 * x); }

// Fitted quantities of a candidate for the parsimony rules: its linear parameters, plus one for a
// nonlinear parameter profiled over a grid on this log's compass (a throttle exponent other than
// the linear default, a lag τ). Choosing the best of several grid values is a fit too: without
// counting it, a profiled family wins ties against a linear one by its extra freedom alone.
int Dof(const Candidate& c) {
  const bool profiled = (c.grid_name == "exponent" && c.grid_value != 1.0) || c.grid_name == "tau_s";
  return c.p() + (profiled ? 1 : 0);
}

// Ramsey's RESET for the reported model: the model's own fitted field f_k = X_k·β (its candidate
// part, the baseline excluded) enters once more as f_k·|f_k| / rms|f|, one coefficient. A right
// form leaves nothing that grows with the square of what it predicts; a linear form fitted to a
// power law or a saturation does (k·I over a·I^p leaves a part along d that follows I²). Significant
// by its cluster-robust Wald test at alpha, and material: it removes at least the materiality share
// of the noise floor's power. One coefficient along the model's own prediction, so manoeuvre
// transients of a 10 Hz replay (spread over every direction) hardly load on it.
std::string ResetFinding(const Analyzer& an, const Evaluated& model, double noise_var, const DiagnoseOptions& o) {
  if (!model.cand || !model.full.ok) return "";
  const Candidate& c = *model.cand;
  const size_t n = c.X.size();
  if (n == 0 || c.p() == 0) return "";
  const Eigen::VectorXd beta = model.full.beta.segment(model.off, c.p());
  std::vector<Vec3> f(n);
  double ms = 0;
  for (size_t k = 0; k < n; ++k) {
    f[k] = c.X[k] * beta;
    ms += f[k].squaredNorm() / static_cast<double>(n);
  }
  if (!(ms > 0)) return "";
  const double rms = std::sqrt(ms);
  Candidate reset = MakeCandidate("reset", {"f_abs_f"}, {1.0}, "");
  for (size_t k = 0; k < n; ++k) reset.X.emplace_back(Mat3X(f[k] * (f[k].norm() / rms)));
  const Evaluated ej = an.Evaluate(Join(c, reset));
  if (!ej.full.ok || ej.cov.size() == 0) return "";
  const int idx = ej.off + c.p();
  const double p = WaldP(ej.full.beta, ej.cov, {idx}, an.G());
  const double gain_ms = std::max(0.0, model.full.sse - ej.full.sse) / an.total_n();
  if (p < o.alpha && gain_ms >= o.materiality * noise_var) {
    return "a part that grows with the square of what the model predicts (a power law or a saturation, not its linear form)";
  }
  return "";
}

}  // namespace

ChannelResult AnalyzeCompass(const ChannelData& ch, const logs::FlightLog& log, const std::vector<std::string>& phases,
                             const DiagnoseOptions& o, const CompassTiming& timing, RngStream* rng) {
  ChannelResult res;
  res.channel = ch.name;
  res.unit = ch.unit;
  res.samples = static_cast<int>(ch.t.size());
  res.not_available = ch.not_available;
  res.timing = timing.report;
  Analyzer an(ch, o);
  res.t_s = ch.t;
  res.residual_before = an.y();
  res.rms_before = std::sqrt(MeanSquare(an.y()));
  const NuisanceReport nu = DescribeNuisance(ch, an.baseline(), o);
  res.nuisance = nu.nuisance;
  res.findings = nu.findings;

  const double noise_sse = NoiseVariance(ch.t, an.y()) * an.total_n();
  Attribution at = Attribute(ch, an, o, rng, noise_sse);
  const size_t F = at.fam_names.size();
  for (CandidateResult& r : at.results) {
    DescaleMisalignment(nu.nuisance.field_scale, &r);
    r.plausible = plausibility::IsPlausible(r.effect, r.magnitude);
    r.physical_range = plausibility::RangeText(r.effect);
  }
  // The library-free set: cluster-robust Wald tests of its two groups (field matrix; current and
  // throttle), Bonferroni over the groups; the in-sample mean square it removes.
  double flex_p = 1.0, flex_gain_ms = 0.0;
  if (ch.flexible.p() > 0 && ch.flexible.X.size() == ch.t.size()) {
    const Evaluated ef = an.Evaluate(ch.flexible);
    if (ef.full.ok && ef.cov.size() > 0) {
      const int off = ef.off, q = ch.flexible.p();
      const int split = std::min(q, kFlexFieldParams);
      const double p1 = WaldP(ef.full.beta, ef.cov, Range(off, off + split), an.G());
      const double p2 = q > split ? WaldP(ef.full.beta, ef.cov, Range(off + split, off + q), an.G()) : 1.0;
      flex_p = std::min(1.0, 2.0 * std::min(p1, p2));
      flex_gain_ms = std::max(0.0, an.baseline().full.sse - ef.full.sse) / an.total_n();
    }
  }
  // Three tests decide that a gap exists, each at alpha/3 (Bonferroni): the library-free regressors
  // and the spectral line (DetectStructure, at alpha/3 each), and, below, the best library candidate.
  const Structure st =
      DetectStructure(ch.t, an.y(), an.baseline().cv_sse, o.materiality, flex_p, flex_gain_ms, 2.0 * o.alpha / 3.0);
  res.noise_rms = std::sqrt(st.noise_var);
  res.noise_floor_ratio = st.power_ratio;
  res.ljung_box_p = st.whiteness_p;
  res.p_value = st.p_value;
  res.gap_detected = st.present;
  const double cv0 = an.baseline().cv_sse;

  // A current-driven soft iron must depend on the current: over a constant field matrix (any
  // residual scale, cross-coupling or misalignment, the library-free set's first group) its partial
  // Wald test must still be significant; with a nearly constant current a constant matrix looks the same.
  Candidate field_matrix;
  if (ch.flexible.p() >= kFlexFieldParams && ch.flexible.X.size() == ch.t.size()) {
    field_matrix = MakeCandidate("field_matrix", {}, {}, "");
    for (int j = 0; j < kFlexFieldParams; ++j) {
      field_matrix.names.push_back(ch.flexible.names[j]);
      field_matrix.scale.push_back(1.0);
    }
    for (const auto& x : ch.flexible.X) field_matrix.X.emplace_back(x.leftCols(kFlexFieldParams));
  }
  // The one-standard-error rule among plausible, significant effects.
  size_t best = F;
  for (size_t f = 0; f < F; ++f) {
    const Evaluated& e = at.all[at.fam_best[f]];
    double pf = std::min(1.0, e.wald_p * static_cast<double>(at.family[at.fam_names[f]].size()) * static_cast<double>(F));
    if (at.fam_names[f] == "current_soft_iron" && field_matrix.p() > 0) {
      const Evaluated ej = an.Evaluate(Join(field_matrix, *e.cand));
      if (ej.full.ok && ej.cov.size() > 0) {
        const double partial = WaldP(ej.full.beta, ej.cov, Range(ej.off + field_matrix.p(), ej.p()), an.G());
        pf = std::max(pf, std::min(1.0, partial * static_cast<double>(F)));
      }
    }
    at.results[f].p_value = pf;
    if (!at.results[f].plausible || pf > o.alpha) continue;
    if (best == F || e.cv_sse < at.all[at.fam_best[best]].cv_sse) best = f;
  }
  size_t chosen = best;
  if (best < F) {
    const Evaluated& eb = at.all[at.fam_best[best]];
    for (size_t f = 0; f < F; ++f) {
      if (f == best || !at.results[f].plausible || at.results[f].p_value > o.alpha) continue;
      const Evaluated& e = at.all[at.fam_best[f]];
      const FoldDiff d = Diff(e.fold_sse, eb.fold_sse);
      const Evaluated& ec = at.all[at.fam_best[chosen]];
      if (d.sum <= d.se && (Dof(*e.cand) < Dof(*ec.cand) || (Dof(*e.cand) == Dof(*ec.cand) && e.cv_sse < ec.cv_sse))) {
        chosen = f;
      }
    }
  }
  // The third detection test: a library candidate is a structure of its own when its (family
  // corrected) Wald test passes at alpha/3 and it removes, on held-out blocks, at least the
  // materiality share of the noise floor's power (a lag of the wiring field or a thermal drift is
  // neither linear in the current and throttle nor a spectral line).
  if (!res.gap_detected && chosen < F) {
    const double gain_ms = (cv0 - at.all[at.fam_best[chosen]].cv_sse) / an.total_n();
    if (at.results[chosen].p_value < o.alpha / 3.0 && gain_ms >= o.materiality * st.noise_var) {
      res.gap_detected = true;
      res.p_value = std::min(res.p_value, std::min(1.0, 3.0 * at.results[chosen].p_value));
    }
  }
  // Timing term: the latency alignment competes on the share of the unaligned baseline residual.
  CandidateResult lat;
  if (timing.latency_ok) {
    lat.effect = "latency";
    lat.magnitude = timing.latency_s;
    lat.magnitude_ci95[0] = timing.latency_ci95_s[0];
    lat.magnitude_ci95[1] = timing.latency_ci95_s[1];
    lat.magnitude_unit = "s";
    lat.params["latency_s"] = timing.latency_s;
    lat.ci95["latency_s"] = {timing.latency_ci95_s[0], timing.latency_ci95_s[1]};
    lat.explained_share = timing.latency_share;
    lat.heldout_shrink = 1.0 - std::sqrt(std::max(0.0, 1.0 - timing.latency_share));
    lat.plausible = plausibility::IsPlausible("latency", timing.latency_s);
    lat.physical_range = plausibility::RangeText("latency");
    lat.parameters = 1;
    lat.probability = std::nan("");
  }
  const double effect_share = chosen < F ? at.results[chosen].explained_share : 0.0;
  // The timing term is judged like a nuisance term (its alignment is part of the baseline): named
  // when nothing beyond the aligned baseline is found and its interval lies beyond its normal range
  // (as the offset's; exact
  // ranges: when its interval clears zero and the alignment removes a material share).
  const bool latency_out =
      timing.latency_ok && lat.plausible &&
      (o.nuisance_ranges == "exact"
           ? (timing.latency_ci95_s[0] > 0 || timing.latency_ci95_s[1] < 0) && timing.latency_share >= o.materiality
           : timing.latency_ci95_s[0] > plausibility::FindRange("latency")->normal_hi);

  std::vector<Vec3> after = an.y();
  double cv_after = cv0;
  std::string second;
  if (!res.gap_detected && nu.out_of_range.empty() && latency_out) {
    res.verdict = "latency";
    res.gap_detected = true;  // a gap, and it is the compass's timing
    lat.selected = true;
    res.explained_share = timing.latency_share;
    res.explanation = fmt::format("nothing beyond the aligned baseline; the compass is {:.0f} ms late against the "
                                  "attitude (normal: {}), and aligning it removes {} of the residual above the noise",
                                  1000 * timing.latency_s, plausibility::RangeText("latency"), Percent(timing.latency_share));
  } else if (!res.gap_detected) {
    res.verdict = nu.out_of_range.empty() ? "none" : nu.out_of_range;
    res.gap_detected = !nu.out_of_range.empty();  // a gap, and it is that term
    res.explanation = nu.out_of_range.empty()
                          ? fmt::format("no structure above the noise floor after the nuisance baseline (power ratio {:.2f})",
                                        st.power_ratio)
                          : "nothing beyond the baseline; the " + nu.out_of_range + " term is outside its normal range";
  } else if (chosen < F && effect_share >= 0.5) {
    CandidateResult& top = at.results[chosen];
    top.selected = true;
    res.verdict = top.effect;
    const Evaluated& e1 = at.all[at.fam_best[chosen]];
    Evaluated model = e1;
    Candidate joint;
    // A second effect earns its place when the pair beats the first by more than one standard error.
    size_t b2 = F;
    for (size_t f = 0; f < F; ++f) {
      if (f == chosen || !at.results[f].plausible || at.results[f].p_value > o.alpha) continue;
      Candidate j = Join(*e1.cand, *at.all[at.fam_best[f]].cand);
      Evaluated ej = an.Evaluate(j);
      if (!ej.full.ok) continue;
      const FoldDiff d = Diff(ej.fold_sse, model.fold_sse);
      const double p_partial = WaldP(ej.full.beta, ej.cov, Range(ej.off + e1.cand->p(), ej.p()), an.G()) * static_cast<double>(F);
      // ... and removes at least the materiality share of the noise floor's power (held out).
      const bool material = (model.cv_sse - ej.cv_sse) / an.total_n() >= o.materiality * st.noise_var;
      if (d.sum < -d.se && p_partial < o.alpha && ej.cv_sse < model.cv_sse && material) {
        b2 = f;
        joint = std::move(j);
        model = std::move(ej);
        model.cand = &joint;
      }
    }
    if (b2 < F) {
      at.results[b2].selected = true;
      second = at.fam_names[b2];
      model = an.Evaluate(joint);
    }
    after = an.After(model);
    cv_after = model.cv_sse;
    res.explained_share = ExplainedShare(cv0, cv_after, noise_sse);
    res.chosen_regressor_name = e1.cand->regressor_name;
    res.chosen_regressor = e1.cand->regressor;
    // Ambiguity: an as-simple, non-nested rival within one standard error.
    for (size_t f = 0; f < F; ++f) {
      if (f == chosen || f == b2 || !at.results[f].plausible || at.results[f].p_value > o.alpha) continue;
      const Evaluated& e = at.all[at.fam_best[f]];
      if (Dof(*e.cand) > Dof(*e1.cand)) continue;
      const FoldDiff d = Diff(e.fold_sse, e1.fold_sse);
      if (d.sum > d.se || Nests(*e.cand, *e1.cand) || Nests(*e1.cand, *e.cand)) continue;
      res.verdict = "ambiguous";
      res.explanation = fmt::format("{} and {} explain the held-out residual equally well ({} and {}): {}", top.effect,
                                    at.fam_names[f], Percent(top.explained_share), Percent(at.results[f].explained_share),
                                    SeparatingManoeuvre(top.effect, at.fam_names[f]));
      break;
    }
    if (res.verdict != "ambiguous" && !second.empty()) res.explanation = "together with " + second;
    // What the reported model leaves must not hold a structure of its own (a line or a drift far
    // above the residual's own spectrum): a model that takes half of a form it cannot describe is
    // not the explanation. A right model leaves only the floor, so this never blocks it.
    const Structure left = DetectStructure(ch.t, after, cv_after, o.materiality, 1.0, 0.0, o.alpha);
    std::string left_found = left.present ? left.found : std::string();
    if (res.verdict != "ambiguous") {
      const std::string reset = ResetFinding(an, model, st.noise_var, o);
      if (!reset.empty()) left_found += (left_found.empty() ? "" : "; ") + reset;
    }
    if (!left_found.empty() && res.verdict != "ambiguous") {
      res.verdict = "unexplained";
      res.explanation = fmt::format("{} explains {} of the held-out residual above the floor, but what it leaves still holds "
                                    "{}: structure no candidate describes",
                                    top.effect, Percent(res.explained_share), left_found);
      top.selected = false;
      if (b2 < F) at.results[b2].selected = false;
      res.chosen_regressor_name.clear();
      res.chosen_regressor.clear();
    }
  } else {
    res.verdict = "unexplained";
    std::string best_txt = "no plausible, significant candidate";
    if (chosen < F) {
      best_txt = fmt::format("best: {}, explained share {}", at.fam_names[chosen], Percent(effect_share));
      after = an.After(at.all[at.fam_best[chosen]]);
      cv_after = at.all[at.fam_best[chosen]].cv_sse;
    }
    const std::string what = st.found.empty() ? "found by a library candidate's test" : st.found;
    res.explanation = "structure above the noise floor (" + what + ") that no plausible candidate explains to half (" + best_txt + ")";
  }
  for (const CandidateResult& r : at.results) {
    if (!r.plausible) {
      res.findings.push_back(fmt::format("{} fits {:.3g} {}, outside its physical range {}: implausible, model mismatch",
                                         r.effect, r.magnitude, r.magnitude_unit, r.physical_range));
    }
  }
  res.heldout_shrink = Shrink(cv_after, cv0);
  if (res.verdict == "latency") res.heldout_shrink = lat.heldout_shrink;
  res.residual_after = after;
  res.where = Locate(ch, an.y(), log, phases);
  if (res.gap_detected) {
    res.residual_left =
        DescribeLeft(ch.t, after, 1.0 - std::max(0.0, ExplainedShare(cv0, cv_after, noise_sse)), Locate(ch, after, log, phases));
  }
  // Best first: selected, then by explained share; nuisance terms and the timing term after effects.
  std::vector<CandidateResult> sorted;
  if (lat.selected) sorted.push_back(lat);
  for (const CandidateResult& t : nu.terms) {
    if (t.effect == res.verdict) {
      sorted.push_back(t);
      sorted.back().selected = true;
    }
  }
  std::vector<size_t> order(F);
  for (size_t f = 0; f < F; ++f) order[f] = f;
  std::sort(order.begin(), order.end(),
            [&](size_t a, size_t b) { return at.results[a].explained_share > at.results[b].explained_share; });
  for (size_t i : order) {
    if (at.results[i].selected) sorted.push_back(at.results[i]);
  }
  for (size_t i : order) {
    if (!at.results[i].selected) sorted.push_back(at.results[i]);
  }
  if (timing.latency_ok && !lat.selected) sorted.push_back(lat);
  for (const CandidateResult& t : nu.terms) {
    if (t.effect != res.verdict) sorted.push_back(t);
  }
  res.candidates = std::move(sorted);
  return res;
}

}  // namespace hexsim::gap::internal
