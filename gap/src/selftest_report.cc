// The selftest's metrics, targets and table from its trials' records (the JSON: selftest_json.cc).
#include <algorithm>
#include <cmath>
#include <map>

#include <fmt/format.h>

#include "selftest_plan.h"

namespace hexsim::gap::internal {
namespace {

void Add(bool hit, Tally* t) {
  t->hits += hit;
  t->trials += 1;
}

// The verdict names one of the injected effects' truth labels.
bool Top1(const ClassTrialRecord& out) {
  return std::any_of(out.injected.begin(), out.injected.end(),
                     [&](const InjectedEffect& x) { return x.label != Effect::kNone && out.verdict == Info(x.label).name; });
}

// An out-of-library family's or a form's trial: not confident, right, named right, its lag.
void AddFormTrial(const ClassTrialRecord& out, SelftestClassStats* st) {
  const std::string& family = out.family;
  if (!family.empty()) st->per_effect[family].hits += out.not_confident;
  st->not_confident += out.not_confident;
  const bool right = out.judged_right.value_or(out.not_confident);
  const bool named = out.named_right.value_or(false);
  st->judged_right += right;
  st->named_right += named;
  st->confident_wrong += !right;
  if (family.empty()) return;
  Add(right, &st->per_form_right[family]);
  Add(named, &st->per_form_named[family]);
  if (out.lag_fit) {
    Add(out.lag_fit->named, &st->per_form_lag_named[family]);
    Add(out.lag_fit->covered, &st->per_form_lag_covered[family]);
  }
}

void AddTrial(const std::string& c, const ClassTrialRecord& out, SelftestClassStats* st_ptr) {
  SelftestClassStats& st = *st_ptr;
  const bool dyn_class = c == "dynamics_one_effect";
  const auto& inj = out.injected;
  if (!out.family.empty()) ++st.per_effect[out.family].trials;
  if (out.dynamics_detected) {
    ++st.dynamics_n;
    st.dynamics_alarm += *out.dynamics_detected;
  }
  ++st.n;
  st.detected += out.gap_detected;
  ++st.verdicts[out.verdict];
  st.any_compass_alarm += out.any_compass_alarm;
  st.left_reported += out.left_reported;
  const bool hit = Top1(out);
  if (c == "two_effects") st.all_in_effects += out.all_in_effects;
  if (c == "one_effect" || c == "two_effects" || dyn_class) {
    st.top1 += hit;
    Add(hit, &st.per_effect[c != "two_effects" ? inj[0].name : inj[0].name + "+" + inj[1].name]);
  }
  if (c == "one_effect" || dyn_class) {
    st.shrink.push_back(out.heldout_shrink);
    st.share.push_back(out.true_share.value_or(0.0));
    if (out.covered) {
      ++st.coverage_n;
      st.covered += *out.covered;
      Add(*out.covered, &st.per_effect_coverage[inj[0].name]);
    }
  }
  if (c == "out_of_library" || c == "beyond_library") AddFormTrial(out, &st);
}

SelftestThreshold SweepThreshold(const SelftestPlan& p, const std::vector<TrialRecord>& outs, size_t first) {
  SelftestThreshold th;
  th.grid_uT_per_A = p.threshold_grid;
  const auto n = static_cast<size_t>(p.o.threshold_trials);
  for (size_t g = 0; g < p.threshold_grid.size(); ++g) {
    int flagged = 0;
    for (size_t k = 0; k < n; ++k) flagged += std::get<ThresholdTrialRecord>(outs[first + g * n + k]).flagged;
    th.flagged_rate.push_back(p.o.threshold_trials > 0 ? static_cast<double>(flagged) / p.o.threshold_trials : 0.0);
  }
  for (size_t i = p.threshold_grid.size(); i-- > 0;) {
    if (th.flagged_rate[i] >= 0.9) th.value_uT_per_A = p.threshold_grid[i];
    else break;
  }
  return th;
}

// The ideal profile's targets (exact logs), and the real profile's (logs at real rates); the
// dynamics channel's beside them (targets_met and the exit code cover both).
void SetTargets(const SelftestPlan& p, SelftestResult* m) {
  const SelftestClassStats& one = m->stats["one_effect"];
  const SelftestClassStats& dyn = m->stats["dynamics_one_effect"];
  const double th = m->threshold.value_uT_per_A;
  const bool th_ok = std::isfinite(th) && th <= 0.1;
  if (p.real) {
    // Forms beyond the library's names: right (named as the effect they are a form of, or not
    // confident) as often as out-of-library families must be not confident.
    const SelftestClassStats& bl = m->stats["beyond_library"];
    m->targets = {{"single_top1_ge_0.90", m->single_top1 >= 0.9},
                  {"overall_top1_ge_0.75", m->overall_top1 >= 0.75},
                  {"false_alarm_le_0.05", m->false_alarm <= 0.05},
                  {"not_confident_ge_0.85", m->not_confident >= 0.85},
                  {"beyond_library_judged_right_ge_0.85", bl.Rate(bl.judged_right) >= 0.85},
                  {"coverage_ge_0.90", m->coverage >= 0.9},
                  {"median_explained_share_ge_0.50", one.MedianShare() >= 0.5},
                  {"current_hard_iron_threshold_le_0.1uT_per_A", th_ok}};
    m->dynamics_targets.reset();  // not run on this profile (reported as such)
  } else {
    m->targets = {{"single_top1_ge_0.90", m->single_top1 >= 0.9},
                  {"overall_top1_ge_0.70", m->overall_top1 >= 0.7},
                  {"false_alarm_le_0.05", m->false_alarm <= 0.05},
                  {"not_confident_ge_0.80", m->not_confident >= 0.8},
                  {"coverage_ge_0.90", m->coverage >= 0.9},
                  // CONTRACTS' one share (explained_share) on both profiles: the held-out shrink's
                  // RMS about zero counts the noise floor, so it measures the injected size against
                  // the noise rather than the diagnosis (it stays printed beside it).
                  {"median_explained_share_ge_0.50", one.MedianShare() >= 0.5},
                  {"current_hard_iron_threshold_le_0.1uT_per_A", th_ok}};
    // The dynamics channel's one-effect target is on the same share as the compasses' (the true
    // effect's explained_share above the channel's noise floor): the held-out shrink, RMS about
    // zero, counts the floor and so measures the injected size against the noise (printed beside).
    m->dynamics_targets = std::map<std::string, bool>{{"false_alarm_le_0.05", m->dynamics_false_alarm <= 0.05},
                                                      {"single_top1_ge_0.90", dyn.Rate(dyn.top1) >= 0.9},
                                                      {"coverage_ge_0.90", dyn.Coverage() >= 0.9},
                                                      {"median_explained_share_ge_0.50", dyn.MedianShare() >= 0.5}};
  }
  m->compass_targets_met = true;
  m->dynamics_targets_met = true;
  for (const auto& [k, v] : m->targets) m->compass_targets_met = m->compass_targets_met && v;
  if (m->dynamics_targets) {
    for (const auto& [k, v] : *m->dynamics_targets) m->dynamics_targets_met = m->dynamics_targets_met && v;
  }
  m->targets_met = m->compass_targets_met && m->dynamics_targets_met;
}

SelftestResult Measure(const SelftestPlan& p, std::vector<TrialRecord> outcomes) {
  SelftestResult m;
  m.options = p.o;
  m.channel = p.channel;
  m.classes = p.classes;
  size_t next = 0;
  for (const Segment& s : p.segments) {
    if (s.cls == "threshold") {
      m.threshold = SweepThreshold(p, outcomes, next);
    } else {
      SelftestClassStats& st = m.stats[s.cls];
      for (int k = 0; k < s.trials; ++k) AddTrial(s.cls, std::get<ClassTrialRecord>(outcomes[next + static_cast<size_t>(k)]), &st);
    }
    for (int k = 0; k < s.trials; ++k) m.trial_classes.push_back(s.cls);
    next += static_cast<size_t>(s.trials);
  }
  const SelftestClassStats& clean = m.stats["clean"];
  const SelftestClassStats& one = m.stats["one_effect"];
  const SelftestClassStats& two = m.stats["two_effects"];
  const SelftestClassStats& ool = m.stats["out_of_library"];
  m.single_top1 = one.Rate(one.top1);
  m.overall_top1 = one.n + two.n > 0 ? static_cast<double>(one.top1 + two.top1) / (one.n + two.n) : 0.0;
  m.false_alarm = clean.Rate(clean.detected);
  m.not_confident = ool.Rate(ool.not_confident);
  m.coverage = one.Coverage();
  m.dynamics_false_alarm = clean.dynamics_n > 0 ? static_cast<double>(clean.dynamics_alarm) / clean.dynamics_n : 0.0;
  SetTargets(p, &m);
  m.trials = std::move(outcomes);
  return m;
}

std::string PerEffectLines(const SelftestClassStats& s) {
  std::string t;
  for (const auto& [e, v] : s.per_effect) {
    const auto it = s.per_effect_coverage.find(e);
    const Tally cov = it == s.per_effect_coverage.end() ? Tally{} : it->second;
    t += fmt::format("      {:<20} top-1 {}/{}  interval covers truth {}/{}\n", e, v.hits, v.trials, cov.hits, cov.trials);
  }
  return t;
}

std::string FormLines(const SelftestClassStats& s, bool named) {
  std::string t;
  for (const auto& [e, v] : s.per_form_right) {
    t += fmt::format("      {:<20} right {}/{}", e, v.hits, v.trials);
    if (named) t += fmt::format(" (named right {}, not confident {})", s.per_form_named.at(e).hits, s.per_effect.at(e).hits);
    const auto lag = s.per_form_lag_named.find(e);
    if (named && lag != s.per_form_lag_named.end()) {
      t += fmt::format("; named current_lag {}/{}, its lag's interval holds the truth {}/{}", lag->second.hits,
                       lag->second.trials, s.per_form_lag_covered.at(e).hits, s.per_form_lag_covered.at(e).trials);
    }
    t += "\n";
  }
  return t;
}

std::string Table(const SelftestPlan& p, const SelftestResult& m) {
  const auto& st = m.stats;
  const SelftestClassStats& clean = st.at("clean");
  const SelftestClassStats& one = st.at("one_effect");
  const SelftestClassStats& two = st.at("two_effects");
  const SelftestClassStats& ool = st.at("out_of_library");
  std::string t = fmt::format("gap selftest ({} profile): {} trials per class, vehicle {}, mission {}, channel {}\n",
                              p.o.profile, p.o.trials, p.o.vehicle, p.o.mission, p.channel);
  t += fmt::format("  clean            false alarms {:5.1f} %  (target <= 5 %; any compass {:.1f} %)\n", 100 * m.false_alarm,
                   100 * clean.Rate(clean.any_compass_alarm));
  t += fmt::format("  one effect       top-1 {:5.1f} %  (target >= 90 %), 95 % interval coverage {:5.1f} % (>= 90 %), "
                   "median explained share of the true effect {:4.0f} % (>= 50 %), median held-out shrink {:4.0f} %; "
                   "leftover reported {:4.0f} %\n",
                   100 * m.single_top1, 100 * m.coverage, 100 * one.MedianShare(), 100 * one.MedianShrink(),
                   100 * one.Rate(one.left_reported));
  t += PerEffectLines(one);
  t += fmt::format("  two effects      top-1 {:5.1f} %; overall top-1 {:5.1f} % (target >= {} %); both in effects {:5.1f} %\n",
                   100 * two.Rate(two.top1), 100 * m.overall_top1, p.real ? 75 : 70, 100 * two.Rate(two.all_in_effects));
  for (const std::string& cls : p.classes) {
    t += fmt::format("      verdicts {:<15}", cls);
    for (const auto& [v, k] : st.at(cls).verdicts) t += fmt::format(" {}:{}", v, k);
    t += "\n";
  }
  if (p.real) {
    t += "  dynamics channel: not run on the real profile (its replay needs the simulator's row rate)\n";
  } else {
    const SelftestClassStats& dyn = st.at("dynamics_one_effect");
    t += fmt::format("  dynamics channel false alarms on clean logs {:5.1f} % (target <= 5 %); one effect top-1 {:5.1f} % "
                     "(>= 90 %), 95 % interval coverage {:5.1f} % (>= 90 %), median explained share of the true effect "
                     "{:4.0f} % (>= 50 %), median held-out shrink {:4.0f} %\n",
                     100 * m.dynamics_false_alarm, 100 * dyn.Rate(dyn.top1), 100 * dyn.Coverage(), 100 * dyn.MedianShare(),
                     100 * dyn.MedianShrink());
    t += PerEffectLines(dyn);
  }
  t += fmt::format("  out of library   not confident (unexplained, ambiguous, partial or leftover reported) {:5.1f} % "
                   "(target >= {} %), confident wrong {:5.1f} %\n",
                   100 * m.not_confident, p.real ? 85 : 80, 100 * ool.Rate(ool.confident_wrong));
  if (p.real) t += FormLines(ool, false);
  if (p.real) {
    const SelftestClassStats& bl = st.at("beyond_library");
    t += fmt::format("  beyond library   right (named as the effect it is a form of, or not confident) {:5.1f} % (target >= 85 %), "
                     "named right {:5.1f} %, confident wrong {:5.1f} %\n",
                     100 * bl.Rate(bl.judged_right), 100 * bl.Rate(bl.named_right), 100 * bl.Rate(bl.confident_wrong));
    t += FormLines(bl, true);
  }
  const double th = m.threshold.value_uT_per_A;
  t += "  current_hard_iron detection threshold: ";
  t += std::isfinite(th) ? fmt::format("{:.3g} uT/A ({:.3g} mG/A)", th, kMilliGaussPerMicroTesla * th) : std::string("not reached");
  t += " (target <= 0.1 uT/A); flagged:";
  for (size_t i = 0; i < p.threshold_grid.size(); ++i) {
    t += fmt::format(" {}:{:.0f}%", p.threshold_grid[i], 100 * m.threshold.flagged_rate[i]);
  }
  t += fmt::format("\n  targets {}; dynamics channel targets {}", m.compass_targets_met ? "met" : "MISSED",
                   p.real ? "not run" : (m.dynamics_targets_met ? "met" : "MISSED:"));
  if (!p.real && m.dynamics_targets) {
    for (const auto& [k, v] : *m.dynamics_targets) {
      if (!v) t += " " + k;
    }
  }
  return t + "\n";
}

}  // namespace

SelftestResult SummariseSelftest(const SelftestPlan& plan, std::vector<TrialRecord> outcomes) {
  SelftestResult res = Measure(plan, std::move(outcomes));
  res.table = Table(plan, res);
  return res;
}

}  // namespace hexsim::gap::internal

namespace hexsim::gap {
namespace {

// The median of s (0 when empty).
double Median(std::vector<double> s) {
  if (s.empty()) return 0.0;
  std::nth_element(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(s.size() / 2), s.end());
  return s[s.size() / 2];
}

}  // namespace

double SelftestClassStats::MedianShrink() const { return Median(shrink); }
double SelftestClassStats::MedianShare() const { return Median(share); }

}  // namespace hexsim::gap
