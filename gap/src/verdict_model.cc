// The decomposition shared by every channel's verdict (see verdict.h): the model grown effect by
// effect, the ambiguity rule, the effects list and the candidates' order.
#include <algorithm>
#include <cmath>
#include <functional>

#include <Eigen/Cholesky>
#include <fmt/format.h>

#include "hexsim/common/plausibility.h"
#include "verdict.h"

namespace hexsim::gap::internal {

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
  // b's residual on a's column space below kNestedResidual of its own energy: a holds b.
  constexpr double kNestedResidual = 1e-3;
  const Eigen::MatrixXd reg = Aaa + Eigen::MatrixXd::Identity(pa, pa) * 1e-12 * Aaa.trace();
  const Eigen::MatrixXd left = Abb - Aab.transpose() * reg.ldlt().solve(Aab);
  return left.trace() < kNestedResidual * tr;
}

bool DelaysModelledField(const Candidate& c) {
  return c.grid_name == "tau_s" && c.grid2_name.empty() && c.names.size() == 1 && c.names[0] == kModelledFieldShare;
}

bool ModelledFieldShareInRange(const CandidateResult& r) {
  const auto a = r.params.find(kModelledFieldShare);
  const auto ci = r.ci95.find(kModelledFieldShare);
  if (a == r.params.end() || ci == r.ci95.end()) return false;
  return a->second > kModelledFieldShareLo && ci->second.lo <= kModelledFieldShareHi;
}

namespace {

std::vector<bool> Admitted(const Attribution& at, const DiagnoseOptions& o, bool plausible_alone) {
  std::vector<bool> ok(at.results.size(), false);
  for (size_t f = 0; f < at.results.size(); ++f) {
    ok[f] = (at.results[f].plausible || !plausible_alone) && at.results[f].p_value <= o.alpha;
    // A profiled lag whose interval reaches zero is no lag: the field follows the current without
    // one, which the current's own families describe (current_lag's unlagged members are its
    // reference, AddLaggedCurrentField).
    if (at.all[at.fam_best[f]].cand->grid_name == "tau_s" && !(at.results[f].magnitude_ci95[0] > 0)) ok[f] = false;
    if (DelaysModelledField(*at.all[at.fam_best[f]].cand) && !ModelledFieldShareInRange(at.results[f])) ok[f] = false;
  }
  return ok;
}

}  // namespace

std::vector<bool> Eligible(const Attribution& at, const DiagnoseOptions& o) { return Admitted(at, o, true); }

std::vector<bool> Joinable(const Attribution& at, const DiagnoseOptions& o) { return Admitted(at, o, false); }

size_t ChooseFirst(const Attribution& at, const std::vector<bool>& eligible) {
  const size_t F = at.fam_names.size();
  size_t best = F;
  for (size_t f = 0; f < F; ++f) {
    if (eligible[f] && (best == F || at.all[at.fam_best[f]].cv_sse < at.all[at.fam_best[best]].cv_sse)) best = f;
  }
  if (best == F) return F;
  // One-standard-error rule: the fewest fitted quantities among the families within one standard
  // error of the best.
  size_t chosen = best;
  const Evaluated& eb = at.all[at.fam_best[best]];
  for (size_t f = 0; f < F; ++f) {
    if (f == best || !eligible[f]) continue;
    const Evaluated& e = at.all[at.fam_best[f]];
    const FoldDiff d = Diff(e.fold_sse, eb.fold_sse);
    const Evaluated& ec = at.all[at.fam_best[chosen]];
    if (d.sum <= d.se && (Dof(*e.cand) < Dof(*ec.cand) || (Dof(*e.cand) == Dof(*ec.cand) && e.cv_sse < ec.cv_sse))) {
      chosen = f;
    }
  }
  return chosen;
}

bool IsMaterial(const Analyzer& an, const Evaluated& e, double cv_before, double noise_var, const DiagnoseOptions& o) {
  return (cv_before - e.cv_sse) / an.total_n() >= o.materiality * noise_var;
}

void DescribePart(const Evaluated& fit, const Eigen::MatrixXd& V, const Candidate& c, int off, CandidateResult* r) {
  const CandidateResult own = *r;
  DescribeAt(c, fit.full.beta, V, off, static_cast<int>(fit.blocks.size()), GridPicks{}, r);
  for (const std::string& g : {c.grid_name, c.grid2_name}) {
    if (g.empty()) continue;
    const auto v = own.params.find(g);
    const auto ci = own.ci95.find(g);
    if (v != own.params.end()) r->params[g] = v->second;
    if (ci != own.ci95.end()) r->ci95[g] = ci->second;
  }
  if (c.grid_name == "tau_s") {
    r->magnitude = own.magnitude;
    r->magnitude_ci95[0] = own.magnitude_ci95[0];
    r->magnitude_ci95[1] = own.magnitude_ci95[1];
    r->magnitude_unit = own.magnitude_unit;
  }
}

bool BesideAnotherCause(const Attribution& at, const std::vector<size_t>& model, size_t f) {
  if (!Info(at.results[f].id).compensable) return true;
  return std::none_of(model.begin(), model.end(), [&](size_t g) { return Info(at.results[g].id).compensable; });
}

// The model as another family joins it: a member whose own columns were taken beside a field
// (Candidate::X_joint, verdict.cc BesideDrive) with its columns as they are, as it would join one, so
// the joining family fits beside the whole effect (a current field joining a first per-axis scale
// taken beside the current's columns took the scale's part along them: 0.099 [0.093, 0.105] µT/A
// for 0.108; scripts/withheld_sim). Alone the model keeps the member's own fit.
namespace {
Candidate AsJoined(const Candidate& model) {
  Candidate c = model;
  if (!c.X_joint.empty() && c.X_joint.size() == c.X.size()) c.X = std::move(c.X_joint);
  c.X_joint.clear();
  return c;
}
}  // namespace

SelectedModel GrowModel(const Analyzer& an, const Attribution& at, size_t first, const std::vector<bool>& eligible,
                        double noise_var, const DiagnoseOptions& o, const std::vector<bool>& joinable,
                        const std::function<void(CandidateResult*)>& judge) {
  SelectedModel m;
  const size_t F = at.fam_names.size();
  m.fams.push_back(first);
  m.joint = std::make_unique<Candidate>(*at.all[at.fam_best[first]].cand);
  m.eval = at.all[at.fam_best[first]];
  m.eval.cand = m.joint.get();
  m.entry_cv_sse.push_back(m.eval.cv_sse);
  // A family refused alone joins only beside effects of other causes (BesideAnotherCause).
  const auto may_join = [&](size_t f) {
    return eligible[f] || (f < joinable.size() && joinable[f] && BesideAnotherCause(at, m.fams, f));
  };
  // A flight log separates a few effects at most; each step fits every remaining family jointly.
  struct Addition {
    size_t f;
    std::unique_ptr<Candidate> joint;
    Evaluated eval;
  };
  while (m.fams.size() < kMaxModelEffects) {
    std::vector<Addition> qualified;
    for (size_t f = 0; f < F; ++f) {
      if (!may_join(f) || std::find(m.fams.begin(), m.fams.end(), f) != m.fams.end()) continue;
      const Candidate& cf = *at.all[at.fam_best[f]].cand;
      auto j = std::make_unique<Candidate>(Join(AsJoined(*m.joint), cf));
      Evaluated ej = an.Evaluate(*j);
      if (!ej.full.ok || ej.cov.size() == 0) continue;
      const FoldDiff d = Diff(ej.fold_sse, m.eval.fold_sse);
      const double p_partial =
          WaldP(ej.full.beta, ej.cov, Range(ej.off + m.joint->p(), ej.p()), an.G()) * static_cast<double>(F);
      // Beats the model by more than one standard error over the folds, significant over it, and
      // material (held out).
      if (!(d.sum < -d.se && p_partial < o.alpha && IsMaterial(an, ej, m.eval.cv_sse, noise_var, o))) continue;
      // Its size where it is judged: in the model it joins (alone it may hold, or be hidden by,
      // the part it shares with the model's effects), inside its physical range.
      if (judge) {
        CandidateResult r = at.results[f];
        DescribePart(ej, JackknifeCov(ej), cf, ej.off + m.joint->p(), &r);
        judge(&r);
        if (!r.plausible) continue;
      }
      qualified.push_back({f, std::move(j), std::move(ej)});
    }
    if (qualified.empty()) break;
    // ChooseFirst's rule among the families that qualify: the best held out, then the fewest fitted
    // quantities within one standard error of it over the folds (a 9-parameter current soft iron
    // spans a 3-parameter current hard iron's field in a nearly level flight, through the vertical
    // field's column, and otherwise joined a misalignment in its place).
    size_t best = 0;
    for (size_t i = 1; i < qualified.size(); ++i) {
      if (qualified[i].eval.cv_sse < qualified[best].eval.cv_sse) best = i;
    }
    size_t chosen = best;
    for (size_t i = 0; i < qualified.size(); ++i) {
      if (i == best) continue;
      const FoldDiff d = Diff(qualified[i].eval.fold_sse, qualified[best].eval.fold_sse);
      const int dof = Dof(*at.all[at.fam_best[qualified[i].f]].cand);
      const int dof_c = Dof(*at.all[at.fam_best[qualified[chosen].f]].cand);
      if (d.sum <= d.se && (dof < dof_c || (dof == dof_c && qualified[i].eval.cv_sse < qualified[chosen].eval.cv_sse))) {
        chosen = i;
      }
    }
    Addition& add = qualified[chosen];
    m.fams.push_back(add.f);
    m.joint = std::move(add.joint);
    m.eval = std::move(add.eval);
    m.eval.cand = m.joint.get();
    m.entry_cv_sse.push_back(m.eval.cv_sse);
  }
  return m;
}

void DescribeJointly(const SelectedModel& m, const Attribution& at, double cv0, double noise_sse,
                     std::vector<CandidateResult>* all) {
  if (m.fams.size() < 2 || !m.eval.full.ok) return;
  const Eigen::MatrixXd V = JackknifeCov(m.eval);
  int off = m.eval.off;
  for (size_t i = 0; i < m.fams.size(); ++i) {
    const size_t f = m.fams[i];
    const Candidate& c = *at.all[at.fam_best[f]].cand;
    DescribePart(m.eval, V, c, off, &(*all)[f]);
    off += c.p();
    if (i > 0 && i < m.entry_cv_sse.size()) {
      // What it adds to the model it joined, as a share of the baseline's structure above the
      // floor (ExplainedShare's denominator), where that is more than its share alone: an effect
      // hidden by the first alone (a small current field beside a large misalignment) is material
      // only over it.
      const double excess = cv0 - std::max(0.0, noise_sse);
      if (excess > 0) {
        const double step = std::clamp((m.entry_cv_sse[i - 1] - m.entry_cv_sse[i]) / excess, -1.0, 1.0);
        (*all)[f].explained_share = std::max((*all)[f].explained_share, step);
      }
    }
  }
}

size_t AmbiguousRival(const Attribution& at, const SelectedModel& m, const std::vector<bool>& eligible) {
  const size_t F = at.fam_names.size();
  const size_t first = m.fams.front();
  const Evaluated& e1 = at.all[at.fam_best[first]];
  for (size_t f = 0; f < F; ++f) {
    if (!eligible[f] || std::find(m.fams.begin(), m.fams.end(), f) != m.fams.end()) continue;
    const Evaluated& e = at.all[at.fam_best[f]];
    if (Dof(*e.cand) > Dof(*e1.cand)) continue;
    const FoldDiff d = Diff(e.fold_sse, e1.fold_sse);
    if (d.sum > d.se || Nests(*e.cand, *e1.cand) || Nests(*e1.cand, *e.cand)) continue;
    return f;
  }
  return F;
}

namespace {

// GrowModel's tests for the joint step model + rival, in words: those it failed.
std::string JoinRefusal(const Analyzer& an, const SelectedModel& m, const Evaluated& ej, int rival_off, size_t families,
                        double noise_var, const DiagnoseOptions& o) {
  std::vector<std::string> why;
  const FoldDiff d = Diff(ej.fold_sse, m.eval.fold_sse);
  if (!(d.sum < -d.se)) {
    why.push_back(fmt::format("held out it beats the model by {:.3g} of the baseline's SSE, within one standard error ({:.3g})",
                              -d.sum / std::max(an.baseline().cv_sse, 1e-300), d.se / std::max(an.baseline().cv_sse, 1e-300)));
  }
  const double p_sandwich =
      std::min(1.0, WaldP(ej.full.beta, ej.cov, Range(rival_off, ej.p()), an.G()) * static_cast<double>(families));
  if (!(p_sandwich < o.alpha)) {
    why.push_back(fmt::format("its part over the model is not significant at the cluster sandwich over {} families (p {:.2g})",
                              families, p_sandwich));
  }
  if (!IsMaterial(an, ej, m.eval.cv_sse, noise_var, o)) why.emplace_back("its held-out gain over the model is not material");
  if (why.empty()) why.emplace_back("another family joined in its place");
  std::string out;
  for (const std::string& w : why) out += (out.empty() ? "" : "; ") + w;
  return out;
}

}  // namespace

bool OneFieldTwoForms(Effect a, Effect b) {
  if (a == Effect::kCurrentSoftIron || b == Effect::kCurrentSoftIron) return false;
  return DrivenByCurrent(a) && DrivenByCurrent(b) && Info(a).kind != Info(b).kind;
}

Tie ResolveTie(const Analyzer& an, const Attribution& at, const SelectedModel& m, size_t rival, double noise_var,
               const DiagnoseOptions& o, const std::function<void(CandidateResult*)>& judge) {
  Tie t;
  t.first = m.fams.front();
  t.rival = rival;
  const Candidate& c1 = *at.all[at.fam_best[t.first]].cand;
  const Candidate& cr = *at.all[at.fam_best[rival]].cand;
  auto joint = std::make_unique<Candidate>(Join(AsJoined(*m.joint), cr));
  Evaluated ej = an.Evaluate(*joint);
  if (!ej.full.ok || ej.cov.size() == 0) return t;
  // The jackknife holds the leverage of the few blocks where the two differ (JackknifeCov): the
  // sandwich is too small exactly there, and a part resolved only by it decides nothing.
  const Eigen::MatrixXd V = JackknifeCov(ej);
  const int rival_off = ej.off + m.joint->p();
  constexpr double kTests = 2.0;  // Bonferroni over the two partial tests
  t.p_first = std::min(1.0, kTests * WaldP(ej.full.beta, V, Range(ej.off, ej.off + c1.p()), an.G()));
  t.p_rival = std::min(1.0, kTests * WaldP(ej.full.beta, V, Range(rival_off, ej.p()), an.G()));
  const bool first_stays = t.p_first < o.alpha, rival_stays = t.p_rival < o.alpha;
  if (first_stays && !rival_stays) t.outcome = TieOutcome::kFirst;
  if (rival_stays && !first_stays) t.outcome = TieOutcome::kRival;
  if (!(first_stays && rival_stays)) return t;
  if (OneFieldTwoForms(at.results[t.first].id, at.results[rival].id)) {
    t.one_field = true;
    t.outcome = TieOutcome::kFirst;
    return t;
  }
  if (m.fams.size() >= kMaxModelEffects) {
    // The first's part stands beside the rival: the model as grown, the rival not added.
    t.model_full = true;
    t.outcome = TieOutcome::kFirst;
    return t;
  }
  if (judge) {
    CandidateResult r = at.results[rival];
    DescribePart(ej, V, cr, rival_off, &r);
    judge(&r);
    t.rival_plausible = r.plausible;
    if (!r.plausible) return t;
  }
  t.outcome = TieOutcome::kBoth;
  t.refused = JoinRefusal(an, m, ej, rival_off, at.fam_names.size(), noise_var, o);
  t.both.fams = m.fams;
  t.both.fams.push_back(rival);
  t.both.entry_cv_sse = m.entry_cv_sse;
  t.both.entry_cv_sse.push_back(ej.cv_sse);
  t.both.joint = std::move(joint);
  t.both.eval = std::move(ej);
  t.both.eval.cand = t.both.joint.get();
  return t;
}

std::string TieFinding(const Tie& t, const Attribution& at) {
  const std::string& a = at.fam_names[t.first];
  const std::string& b = at.fam_names[t.rival];
  const std::string head = fmt::format(
      "{} and {} explain the held-out residual equally well alone; fitted together, {}'s part beside {} has p {:.2g} "
      "and {}'s beside {} p {:.2g} (partial Wald, block jackknife, Bonferroni over the two)",
      a, b, a, b, t.p_first, b, a, t.p_rival);
  switch (t.outcome) {
    case TieOutcome::kFirst:
      if (t.one_field) {
        return head + fmt::format(": both stay significant, and both describe the motors' field: it follows neither the "
                                  "current nor the throttle in proportion (a power law, a saturation or a lag); {} is "
                                  "reported, its form not established",
                                  a);
      }
      if (t.model_full) {
        return head + fmt::format(": both stay significant; the model already holds {} effects, the most a flight log "
                                  "separates: {} is not added",
                                  kMaxModelEffects, b);
      }
      return head + fmt::format(": the variation they do not share decides for {}", a);
    case TieOutcome::kRival:
      return head + fmt::format(": the variation they do not share decides for {}", b);
    case TieOutcome::kBoth:
      return head + fmt::format(": both are effects (the model did not add {} step by step: {})", b, t.refused);
    case TieOutcome::kNeither:
      break;
  }
  return head + (t.rival_plausible ? ": neither stays significant beside the other"
                                   : fmt::format(": {}'s size beside {} is outside its physical range", b, a));
}

EffectShare ToEffect(const CandidateResult& k, double share, const std::string& source) {
  EffectShare e;
  e.effect = k.effect;
  e.id = k.id;
  e.magnitude = k.magnitude;
  e.ci95 = {k.magnitude_ci95[0], k.magnitude_ci95[1]};
  e.unit = k.magnitude_unit;
  e.explained_share = share;
  e.source = source;
  // The autopilot's unit: ArduPilot's COMPASS_MOT is in mGauss per ampere (1 µT = 10 mG); a
  // throttle or per-motor form carries its battery-current equivalent.
  const auto eq = k.params.find("current_equivalent_uT_per_A");
  const auto eq_ci = k.ci95.find("current_equivalent_uT_per_A");
  if (k.magnitude_unit == "uT/A") {
    e.autopilot_unit = "mG/A";
    e.autopilot_factor = kMilliGaussPerMicroTesla;
  } else if (eq != k.params.end() && eq_ci != k.ci95.end() && k.magnitude != 0) {
    e.autopilot_unit = "mG/A";
    e.autopilot_factor = kMilliGaussPerMicroTesla * eq->second / k.magnitude;
  } else if (k.magnitude_unit == "uT") {
    e.autopilot_unit = "mG";
    e.autopilot_factor = kMilliGaussPerMicroTesla;
  } else if (k.magnitude_unit == "s") {
    e.autopilot_unit = "ms";
    e.autopilot_factor = 1000.0;
  }
  return e;
}

void RefreshEffects(ChannelResult* res) {
  for (EffectShare& e : res->effects) {
    for (const CandidateResult& k : res->candidates) {
      if (k.selected && k.effect == e.effect) {
        e = ToEffect(k, e.explained_share, e.source);
        if (k.id == Effect::kCurrentLag) res->timing.current_field_lag = FieldLag(k, e.explained_share);
        break;
      }
    }
  }
}

LagReport FieldLag(const CandidateResult& k, double share) {
  LagReport l;
  l.present = true;
  l.value_s = k.magnitude;
  l.ci95_s = {k.magnitude_ci95[0], k.magnitude_ci95[1]};
  l.against = "current_A";
  // Resolved from no lag (the modelled one; Eligible), and inside its physical range.
  l.resolved = k.magnitude_ci95[0] > 0;
  l.plausible = k.plausible;
  l.explained_share = share;
  return l;
}

void SortEffects(std::vector<EffectShare>* effects) {
  std::stable_sort(effects->begin(), effects->end(),
                   [](const EffectShare& a, const EffectShare& b) { return a.explained_share > b.explained_share; });
}

std::vector<CandidateResult> OrderCandidates(const std::vector<EffectShare>& effects, std::vector<CandidateResult> all) {
  std::vector<CandidateResult> out;
  std::vector<bool> used(all.size(), false);
  for (const EffectShare& e : effects) {
    for (size_t i = 0; i < all.size(); ++i) {
      if (!used[i] && all[i].selected && all[i].effect == e.effect) {
        out.push_back(all[i]);
        used[i] = true;
        break;
      }
    }
  }
  std::vector<size_t> rest;
  for (size_t i = 0; i < all.size(); ++i) {
    if (!used[i]) rest.push_back(i);
  }
  // Library candidates by explained share, then the timing and nuisance terms.
  std::stable_sort(rest.begin(), rest.end(), [&](size_t a, size_t b) {
    const bool ta = all[a].nuisance_term || all[a].id == Effect::kLatency;
    const bool tb = all[b].nuisance_term || all[b].id == Effect::kLatency;
    if (ta != tb) return tb;
    return !ta && all[a].explained_share > all[b].explained_share;
  });
  for (size_t i : rest) out.push_back(all[i]);
  return out;
}

std::string AtExponent(const CandidateResult& k) {
  const auto ex = k.params.find("exponent");
  return ex != k.params.end() ? fmt::format(" at exponent {:.3g}", ex->second) : std::string();
}

std::string RefusedFinding(const CandidateResult& k, bool beside_a_model) {
  return fmt::format("{} fits {:.3g} {}{}, outside its physical range {}: implausible, model mismatch ({})", k.effect,
                     k.magnitude, k.magnitude_unit, AtExponent(k), k.physical_range,
                     beside_a_model ? "refused although it explains more than the reported effects"
                                    : "refused: why no effect is reported");
}

ModelChoice ChooseModel(const Analyzer& an, const Attribution& at, size_t first, const std::vector<bool>& eligible,
                        double noise_var, const DiagnoseOptions& o, const std::vector<bool>& joinable,
                        const std::function<void(CandidateResult*)>& judge) {
  ModelChoice c;
  c.m = GrowModel(an, at, first, eligible, noise_var, o, joinable, judge);
  const size_t rival = AmbiguousRival(at, c.m, eligible);
  if (rival >= at.fam_names.size()) return c;
  Tie t = ResolveTie(an, at, c.m, rival, noise_var, o, judge);
  c.tie = TieFinding(t, at);
  c.rival = rival;
  switch (t.outcome) {
    case TieOutcome::kFirst:
      break;
    case TieOutcome::kRival:
      c.m = GrowModel(an, at, rival, eligible, noise_var, o, joinable, judge);
      break;
    case TieOutcome::kBoth:
      c.m = std::move(t.both);
      break;
    case TieOutcome::kNeither:
      c.ambiguous = true;
      break;
  }
  return c;
}

std::string TieUndecided(const Attribution& at, size_t first, size_t rival) {
  return fmt::format("{} and {} explain the held-out residual equally well ({:.0f} % and {:.0f} %), and fitted together "
                     "neither decides: {}",
                     at.fam_names[first], at.fam_names[rival], 100 * at.results[first].explained_share,
                     100 * at.results[rival].explained_share,
                     SeparatingManoeuvre(at.results[first].id, at.results[rival].id));
}

}  // namespace hexsim::gap::internal
