// The selftest's metrics, targets, JSON (hexsim.gap_selftest/1) and table from its trials' outcomes.
#include <algorithm>
#include <cmath>
#include <map>

#include <fmt/format.h>

#include "selftest_plan.h"

namespace hexsim::gap::internal {
namespace {

using Json = nlohmann::json;
using Counts = std::pair<int, int>;  // (hits, trials)

struct ClassStats {
  int n = 0, top1 = 0, detected = 0, not_confident = 0, confident_wrong = 0, covered = 0, coverage_n = 0;
  int any_compass_alarm = 0;
  int all_in_effects = 0;                  // two effects: both listed in `effects`
  int judged_right = 0, named_right = 0;   // forms: right (named right or not confident), named right
  int left_reported = 0;                   // the leftover reported beside the headline
  int dynamics_alarm = 0, dynamics_n = 0;  // clean logs: gap flagged on the dynamics channel
  std::vector<double> shrink, share;
  std::map<std::string, Counts> per_effect;           // effect → (top1, n); a family → (not confident, n)
  std::map<std::string, Counts> per_effect_coverage;  // effect → (covered, n)
  std::map<std::string, Counts> per_form_named;       // form → (named right, n)
  std::map<std::string, Counts> per_form_right;       // form → (judged right, n)
  std::map<std::string, Counts> per_form_lag_named;   // lagged form → (named current_lag, n)
  std::map<std::string, Counts> per_form_lag_covered; // lagged form → (its lag's interval holds the truth, n)
  std::map<std::string, int> verdicts;                // verdict → count
  double Rate(int k) const { return n > 0 ? static_cast<double>(k) / n : 0.0; }
  static double Median(std::vector<double> s) {
    if (s.empty()) return 0.0;
    std::nth_element(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(s.size() / 2), s.end());
    return s[s.size() / 2];
  }
  double MedianShrink() const { return Median(shrink); }
  double MedianShare() const { return Median(share); }
  double Coverage() const { return coverage_n > 0 ? static_cast<double>(covered) / coverage_n : 0.0; }
};

bool Flag(const Json& out, const char* key) { return out.contains(key) && out.at(key).get<bool>(); }

void AddTrial(const std::string& c, const Json& out, ClassStats* st_ptr) {
  ClassStats& st = *st_ptr;
  const bool dyn_class = c == "dynamics_one_effect";
  const std::string verdict = out.at("verdict").get<std::string>();
  const std::string family = out.at("family").get<std::string>();
  const auto inj = out.at("effects").get<std::vector<std::string>>();
  const auto labels = out.at("labels").get<std::vector<std::string>>();
  if (!family.empty()) ++st.per_effect[family].second;
  if (out.contains("dynamics_detected")) {
    ++st.dynamics_n;
    st.dynamics_alarm += out["dynamics_detected"].get<bool>();
  }
  ++st.n;
  st.detected += out.at("gap_detected").get<bool>();
  ++st.verdicts[verdict];
  st.any_compass_alarm += out.at("any_compass_alarm").get<bool>();
  st.left_reported += Flag(out, "left_reported");
  const bool hit = std::find(labels.begin(), labels.end(), verdict) != labels.end();
  if (c == "two_effects") st.all_in_effects += out.at("all_in_effects").get<bool>();
  if (c == "one_effect" || c == "two_effects" || dyn_class) {
    st.top1 += hit;
    auto& pe = st.per_effect[c != "two_effects" ? inj[0] : inj[0] + "+" + inj[1]];
    pe.first += hit;
    pe.second += 1;
  }
  if (c == "one_effect" || dyn_class) {
    st.shrink.push_back(out.at("heldout_shrink").get<double>());
    st.share.push_back(out.at("true_share").get<double>());
    for (const auto& in : out.at("covered")) {
      ++st.coverage_n;
      st.covered += in.get<bool>();
      auto& pc = st.per_effect_coverage[inj[0]];
      pc.first += in.get<bool>();
      pc.second += 1;
    }
  }
  if (c == "out_of_library" || c == "beyond_library") {
    if (!family.empty()) st.per_effect[family].first += out.at("not_confident").get<bool>();
    st.not_confident += out.at("not_confident").get<bool>();
    const bool right = out.contains("judged_right") ? out.at("judged_right").get<bool>() : out.at("not_confident").get<bool>();
    st.judged_right += right;
    st.named_right += Flag(out, "named_right");
    st.confident_wrong += !right;
    if (!family.empty()) {
      st.per_form_right[family].first += right;
      st.per_form_right[family].second += 1;
      st.per_form_named[family].first += Flag(out, "named_right");
      st.per_form_named[family].second += 1;
      if (out.contains("lag_named")) {
        st.per_form_lag_named[family].first += Flag(out, "lag_named");
        st.per_form_lag_named[family].second += 1;
        st.per_form_lag_covered[family].first += Flag(out, "lag_covered");
        st.per_form_lag_covered[family].second += 1;
      }
    }
  }
}

// The detection threshold of current_hard_iron: the smallest magnitude flagged in ≥ 90 % of trials
// (and at every larger magnitude of the grid).
struct Threshold {
  std::vector<double> flagged_rate;
  double value = std::nan("");
};

Threshold SweepThreshold(const SelftestPlan& p, const std::vector<Json>& outs) {
  Threshold th;
  for (size_t g = 0; g < p.threshold_grid.size(); ++g) {
    int flagged = 0;
    for (int k = 0; k < p.o.threshold_trials; ++k) flagged += outs[g * static_cast<size_t>(p.o.threshold_trials) + static_cast<size_t>(k)].at("flagged").get<bool>();
    th.flagged_rate.push_back(p.o.threshold_trials > 0 ? static_cast<double>(flagged) / p.o.threshold_trials : 0.0);
  }
  for (size_t i = p.threshold_grid.size(); i-- > 0;) {
    if (th.flagged_rate[i] >= 0.9) th.value = p.threshold_grid[i];
    else break;
  }
  return th;
}

struct Metrics {
  std::map<std::string, ClassStats> stats;
  Threshold threshold;
  double single_top1 = 0, overall_top1 = 0, false_alarm = 0, not_confident = 0, coverage = 0;
  double dyn_false_alarm = 0;
  Json targets, dynamics_targets;
  bool met = true, dyn_met = true;
};

// The ideal profile's targets (exact logs), and the real profile's (logs at real rates); the
// dynamics channel's beside them (targets_met and the exit code cover both).
void SetTargets(const SelftestPlan& p, Metrics* m) {
  const ClassStats& one = m->stats["one_effect"];
  const ClassStats& dyn = m->stats["dynamics_one_effect"];
  const double th = m->threshold.value;
  const bool th_ok = std::isfinite(th) && th <= 0.1;
  if (p.real) {
    // Forms beyond the library's names: right (named as the effect they are a form of, or not
    // confident) as often as out-of-library families must be not confident.
    const ClassStats& bl = m->stats["beyond_library"];
    m->targets = {{"single_top1_ge_0.90", m->single_top1 >= 0.9},
                  {"overall_top1_ge_0.75", m->overall_top1 >= 0.75},
                  {"false_alarm_le_0.05", m->false_alarm <= 0.05},
                  {"not_confident_ge_0.85", m->not_confident >= 0.85},
                  {"beyond_library_judged_right_ge_0.85", bl.Rate(bl.judged_right) >= 0.85},
                  {"coverage_ge_0.90", m->coverage >= 0.9},
                  {"median_explained_share_ge_0.50", one.MedianShare() >= 0.5},
                  {"current_hard_iron_threshold_le_0.1uT_per_A", th_ok}};
    m->dynamics_targets = nullptr;  // not run on this profile (reported as such)
  } else {
    m->targets = {{"single_top1_ge_0.90", m->single_top1 >= 0.9},
                  {"overall_top1_ge_0.70", m->overall_top1 >= 0.7},
                  {"false_alarm_le_0.05", m->false_alarm <= 0.05},
                  {"not_confident_ge_0.80", m->not_confident >= 0.8},
                  {"coverage_ge_0.90", m->coverage >= 0.9},
                  {"median_shrink_ge_0.50", one.MedianShrink() >= 0.5},
                  {"current_hard_iron_threshold_le_0.1uT_per_A", th_ok}};
    m->dynamics_targets = {{"false_alarm_le_0.05", m->dyn_false_alarm <= 0.05},
                           {"single_top1_ge_0.90", dyn.Rate(dyn.top1) >= 0.9},
                           {"coverage_ge_0.90", dyn.Coverage() >= 0.9},
                           {"median_shrink_ge_0.50", dyn.MedianShrink() >= 0.5}};
    for (const auto& [k, v] : m->dynamics_targets.items()) m->dyn_met = m->dyn_met && v.get<bool>();
  }
  for (const auto& [k, v] : m->targets.items()) m->met = m->met && v.get<bool>();
}

Metrics Measure(const SelftestPlan& p, const std::vector<Json>& outcomes) {
  Metrics m;
  size_t next = 0;
  for (const Segment& s : p.segments) {
    if (s.cls == "threshold") {
      m.threshold = SweepThreshold(p, std::vector<Json>(outcomes.begin() + static_cast<std::ptrdiff_t>(next),
                                                        outcomes.begin() + static_cast<std::ptrdiff_t>(next) + s.trials));
    } else {
      ClassStats& st = m.stats[s.cls];
      for (int k = 0; k < s.trials; ++k) AddTrial(s.cls, outcomes[next + static_cast<size_t>(k)], &st);
    }
    next += static_cast<size_t>(s.trials);
  }
  const ClassStats& clean = m.stats["clean"];
  const ClassStats& one = m.stats["one_effect"];
  const ClassStats& two = m.stats["two_effects"];
  const ClassStats& ool = m.stats["out_of_library"];
  m.single_top1 = one.Rate(one.top1);
  m.overall_top1 = one.n + two.n > 0 ? static_cast<double>(one.top1 + two.top1) / (one.n + two.n) : 0.0;
  m.false_alarm = clean.Rate(clean.detected);
  m.not_confident = ool.Rate(ool.not_confident);
  m.coverage = one.Coverage();
  m.dyn_false_alarm = clean.dynamics_n > 0 ? static_cast<double>(clean.dynamics_alarm) / clean.dynamics_n : 0.0;
  SetTargets(p, &m);
  return m;
}

Json ClassJson(const SelftestPlan& p, const std::string& cname, const ClassStats& s, const Metrics& m) {
  Json cj = {{"class", cname},
             {"trials", s.n},
             {"gap_detected_rate", s.Rate(s.detected)},
             {"any_compass_alarm_rate", s.Rate(s.any_compass_alarm)},
             {"leftover_reported_rate", s.Rate(s.left_reported)},
             {"verdicts", s.verdicts}};
  if (cname == "one_effect" || cname == "two_effects" || cname == "dynamics_one_effect") {
    cj["top1_rate"] = s.Rate(s.top1);
    Json pe = Json::object();
    for (const auto& [e, v] : s.per_effect) pe[e] = {{"top1", v.first}, {"trials", v.second}};
    for (const auto& [e, v] : s.per_effect_coverage) pe[e]["covered"] = v.first, pe[e]["coverage_trials"] = v.second;
    cj["per_effect"] = pe;
  }
  if (cname == "one_effect") {
    cj["coverage_95"] = m.coverage;
    cj["median_heldout_shrink"] = s.MedianShrink();
    cj["median_explained_share"] = s.MedianShare();
  }
  if (cname == "dynamics_one_effect") {
    cj["channel"] = "dynamics";
    cj["coverage_95"] = s.Coverage();
    cj["median_heldout_shrink"] = s.MedianShrink();
  }
  if (cname == "two_effects") cj["both_in_effects_rate"] = s.Rate(s.all_in_effects);
  if (cname == "clean") {
    cj["false_alarm_rate"] = m.false_alarm;
    cj["dynamics_false_alarm_rate"] = m.dyn_false_alarm;
  }
  if (cname == "out_of_library" || cname == "beyond_library") {
    if (p.real) {
      Json pf = Json::object();
      for (const auto& [e, v] : s.per_effect) pf[e] = {{"not_confident", v.first}, {"trials", v.second}};
      for (const auto& [e, v] : s.per_form_right) pf[e]["judged_right"] = v.first;
      for (const auto& [e, v] : s.per_form_named) pf[e]["named_right"] = v.first;
      for (const auto& [e, v] : s.per_form_lag_named) pf[e]["named_current_lag"] = v.first;
      for (const auto& [e, v] : s.per_form_lag_covered) pf[e]["lag_covered"] = v.first;
      cj["per_family"] = pf;
    }
    // Not a confident wrong answer: unexplained, ambiguous, partial, or its leftover reported; a form
    // beyond the library is also right when named as the effect it is a form of.
    cj["not_confident_rate"] = s.Rate(s.not_confident);
    cj["judged_right_rate"] = s.Rate(s.judged_right);
    cj["named_right_rate"] = s.Rate(s.named_right);
    cj["confident_wrong_rate"] = s.Rate(s.confident_wrong);
  }
  return cj;
}

Json ToJson(const SelftestPlan& p, const Metrics& m, const std::vector<Json>& outcomes) {
  Json j;
  j["schema"] = "hexsim.gap_selftest/1";
  j["profile"] = p.o.profile;
  j["trials_per_class"] = p.o.trials;
  j["seed"] = p.o.seed;
  j["vehicle"] = p.o.vehicle;
  j["mission"] = p.o.mission;
  j["channel"] = p.channel;
  j["classes"] = Json::array();
  for (const std::string& c : p.classes) j["classes"].push_back(ClassJson(p, c, m.stats.at(c), m));
  j["overall_top1_rate"] = m.overall_top1;
  const double th = m.threshold.value;
  j["detection_threshold"] = {{"current_hard_iron",
                               {{"uT_per_A", std::isfinite(th) ? Json(th) : Json(nullptr)},
                                {"grid_uT_per_A", p.threshold_grid},
                                {"flagged_rate", m.threshold.flagged_rate},
                                {"trials_per_magnitude", p.o.threshold_trials}}}};
  // Every trial's outcome in trial order (SelftestPlan::segments), to read a failure from.
  j["trials"] = Json::array();
  for (size_t i = 0; i < outcomes.size(); ++i) {
    Json tj = outcomes[i];
    tj["class"] = Locate(p, i).segment->cls;
    j["trials"].push_back(std::move(tj));
  }
  j["targets"] = m.targets;
  j["targets_met"] = m.met && m.dyn_met;
  j["compass_targets_met"] = m.met;
  j["dynamics_targets"] = m.dynamics_targets;
  j["dynamics_targets_met"] = m.dyn_met;
  return j;
}

std::string PerEffectLines(const ClassStats& s) {
  std::string t;
  for (const auto& [e, v] : s.per_effect) {
    const auto it = s.per_effect_coverage.find(e);
    const Counts cov = it == s.per_effect_coverage.end() ? Counts{0, 0} : it->second;
    t += fmt::format("      {:<20} top-1 {}/{}  interval covers truth {}/{}\n", e, v.first, v.second, cov.first, cov.second);
  }
  return t;
}

std::string FormLines(const ClassStats& s, bool named) {
  std::string t;
  for (const auto& [e, v] : s.per_form_right) {
    t += fmt::format("      {:<20} right {}/{}", e, v.first, v.second);
    if (named) t += fmt::format(" (named right {}, not confident {})", s.per_form_named.at(e).first, s.per_effect.at(e).first);
    const auto lag = s.per_form_lag_named.find(e);
    if (named && lag != s.per_form_lag_named.end()) {
      t += fmt::format("; named current_lag {}/{}, its lag's interval holds the truth {}/{}", lag->second.first,
                       lag->second.second, s.per_form_lag_covered.at(e).first, s.per_form_lag_covered.at(e).second);
    }
    t += "\n";
  }
  return t;
}

std::string Table(const SelftestPlan& p, const Metrics& m) {
  const auto& st = m.stats;
  const ClassStats& clean = st.at("clean");
  const ClassStats& one = st.at("one_effect");
  const ClassStats& two = st.at("two_effects");
  const ClassStats& ool = st.at("out_of_library");
  std::string t = fmt::format("gap selftest ({} profile): {} trials per class, vehicle {}, mission {}, channel {}\n",
                              p.o.profile, p.o.trials, p.o.vehicle, p.o.mission, p.channel);
  t += fmt::format("  clean            false alarms {:5.1f} %  (target <= 5 %; any compass {:.1f} %)\n", 100 * m.false_alarm,
                   100 * clean.Rate(clean.any_compass_alarm));
  t += fmt::format("  one effect       top-1 {:5.1f} %  (target >= 90 %), 95 % interval coverage {:5.1f} % (>= 90 %), "
                   "median held-out shrink {:4.0f} % (>= 50 %); leftover reported {:4.0f} %\n",
                   100 * m.single_top1, 100 * m.coverage, 100 * one.MedianShrink(), 100 * one.Rate(one.left_reported));
  t += PerEffectLines(one);
  t += fmt::format("  two effects      top-1 {:5.1f} %; overall top-1 {:5.1f} % (target >= {} %); both in effects {:5.1f} %\n",
                   100 * two.Rate(two.top1), 100 * m.overall_top1, p.real ? 75 : 70, 100 * two.Rate(two.all_in_effects));
  for (const std::string& cls : p.classes) {
    t += fmt::format("      verdicts {:<15}", cls);
    for (const auto& [v, k] : st.at(cls).verdicts) t += fmt::format(" {}:{}", v, k);
    t += "\n";
  }
  if (p.real) {
    t += fmt::format("  median explained share of the true effect {:4.0f} % (target >= 50 %)\n", 100 * one.MedianShare());
    t += "  dynamics channel: not run on the real profile (its replay needs the simulator's row rate)\n";
  } else {
    const ClassStats& dyn = st.at("dynamics_one_effect");
    t += fmt::format("  dynamics channel false alarms on clean logs {:5.1f} % (target <= 5 %); one effect top-1 {:5.1f} %, "
                     "95 % interval coverage {:5.1f} %, median held-out shrink {:4.0f} %\n",
                     100 * m.dyn_false_alarm, 100 * dyn.Rate(dyn.top1), 100 * dyn.Coverage(), 100 * dyn.MedianShrink());
    t += PerEffectLines(dyn);
  }
  t += fmt::format("  out of library   not confident (unexplained, ambiguous, partial or leftover reported) {:5.1f} % "
                   "(target >= {} %), confident wrong {:5.1f} %\n",
                   100 * m.not_confident, p.real ? 85 : 80, 100 * ool.Rate(ool.confident_wrong));
  if (p.real) t += FormLines(ool, false);
  if (p.real) {
    const ClassStats& bl = st.at("beyond_library");
    t += fmt::format("  beyond library   right (named as the effect it is a form of, or not confident) {:5.1f} % (target >= 85 %), "
                     "named right {:5.1f} %, confident wrong {:5.1f} %\n",
                     100 * bl.Rate(bl.judged_right), 100 * bl.Rate(bl.named_right), 100 * bl.Rate(bl.confident_wrong));
    t += FormLines(bl, true);
  }
  const double th = m.threshold.value;
  t += "  current_hard_iron detection threshold: ";
  t += std::isfinite(th) ? fmt::format("{:.3g} uT/A ({:.3g} mG/A)", th, kMilliGaussPerMicroTesla * th) : std::string("not reached");
  t += " (target <= 0.1 uT/A); flagged:";
  for (size_t i = 0; i < p.threshold_grid.size(); ++i) {
    t += fmt::format(" {}:{:.0f}%", p.threshold_grid[i], 100 * m.threshold.flagged_rate[i]);
  }
  t += fmt::format("\n  targets {}; dynamics channel targets {}", m.met ? "met" : "MISSED",
                   p.real ? "not run" : (m.dyn_met ? "met" : "MISSED:"));
  if (!p.real) {
    for (const auto& [k, v] : m.dynamics_targets.items()) {
      if (!v.get<bool>()) t += " " + k;
    }
  }
  return t + "\n";
}

}  // namespace

SelftestResult SummariseSelftest(const SelftestPlan& plan, const std::vector<Json>& outcomes) {
  const Metrics m = Measure(plan, outcomes);
  SelftestResult res;
  res.targets_met = m.met && m.dyn_met;
  res.json = ToJson(plan, m, outcomes);
  res.table = Table(plan, m);
  return res;
}

}  // namespace hexsim::gap::internal
