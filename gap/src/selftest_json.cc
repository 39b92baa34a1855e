// hexsim.gap_selftest/1: the typed selftest result and its trial records serialised, and a record
// read back (what a runner passes between processes; see selftest_json.h).
#include "hexsim/gap/selftest_json.h"

#include <cmath>
#include <limits>
#include <string>
#include <utility>

namespace hexsim::gap {
namespace {

using Json = nlohmann::json;

// nlohmann writes a non-finite number as null: read it back as NaN.
double NumberOrNaN(const Json& j) { return j.is_null() ? std::numeric_limits<double>::quiet_NaN() : j.get<double>(); }

std::array<double, 2> Ci95FromJson(const Json& j) { return {NumberOrNaN(j.at(0)), NumberOrNaN(j.at(1))}; }

// The JSON name of a truth label: the registered effect's, or the injected form's own.
std::string LabelName(const InjectedEffect& x) { return x.label != Effect::kNone ? Info(x.label).name : x.name; }

Json ClassRecordJson(const ClassTrialRecord& r) {
  Json out = {{"family", r.family},
              {"verdict", r.verdict},
              {"gap_detected", r.gap_detected},
              {"heldout_shrink", r.heldout_shrink},
              {"any_compass_alarm", r.any_compass_alarm},
              {"effects", Json::array()},
              {"labels", Json::array()},
              {"covered", Json::array()},
              {"left_reported", r.left_reported},
              {"not_confident", r.not_confident},
              {"all_in_effects", r.all_in_effects},
              {"true_magnitude", r.true_magnitude},
              {"explained_share", r.explained_share},
              {"selected", r.selected},
              {"reported", Json::object()}};
  for (const InjectedEffect& x : r.injected) {
    out["effects"].push_back(x.name);
    out["labels"].push_back(LabelName(x));
  }
  if (r.covered) out["covered"].push_back(*r.covered);
  if (r.named_right) out["named_right"] = *r.named_right;
  if (r.judged_right) out["judged_right"] = *r.judged_right;
  if (r.true_lag_s) out["true_lag_s"] = *r.true_lag_s;
  if (r.lag_fit) {
    const LagFit& f = *r.lag_fit;
    out["lag_fit"] = {{"tau_s", f.tau_s}, {"ci95", f.ci95_s}, {"selected", f.selected}, {"plausible", f.plausible}};
    out["lag_named"] = f.named;
    out["lag_covered"] = f.covered;
  }
  if (r.dynamics_detected) out["dynamics_detected"] = *r.dynamics_detected;
  if (r.true_share) out["true_share"] = *r.true_share;
  for (const ReportedEffect& e : r.reported) {
    out["reported"][Info(e.effect).name] = {
        {"magnitude", e.magnitude}, {"ci95", e.ci95}, {"explained_share", e.explained_share}, {"selected", e.selected}};
  }
  return out;
}

ClassTrialRecord ClassRecordFromJson(const Json& j) {
  ClassTrialRecord r;
  r.family = j.at("family").get<std::string>();
  r.verdict = j.at("verdict").get<std::string>();
  r.gap_detected = j.at("gap_detected").get<bool>();
  r.heldout_shrink = NumberOrNaN(j.at("heldout_shrink"));
  r.any_compass_alarm = j.at("any_compass_alarm").get<bool>();
  const Json& names = j.at("effects");
  const Json& labels = j.at("labels");
  for (size_t i = 0; i < names.size(); ++i) r.injected.push_back({names.at(i).get<std::string>(), EffectFromName(labels.at(i).get<std::string>())});
  for (const Json& c : j.at("covered")) r.covered = c.get<bool>();
  r.left_reported = j.at("left_reported").get<bool>();
  r.not_confident = j.at("not_confident").get<bool>();
  r.all_in_effects = j.at("all_in_effects").get<bool>();
  for (const Json& m : j.at("true_magnitude")) r.true_magnitude.push_back(NumberOrNaN(m));
  r.explained_share = NumberOrNaN(j.at("explained_share"));
  r.selected = j.at("selected").get<std::string>();
  if (j.contains("named_right")) r.named_right = j.at("named_right").get<bool>();
  if (j.contains("judged_right")) r.judged_right = j.at("judged_right").get<bool>();
  if (j.contains("true_lag_s")) r.true_lag_s = NumberOrNaN(j.at("true_lag_s"));
  if (j.contains("lag_fit")) {
    const Json& f = j.at("lag_fit");
    r.lag_fit = LagFit{NumberOrNaN(f.at("tau_s")), Ci95FromJson(f.at("ci95")), f.at("selected").get<bool>(), f.at("plausible").get<bool>(),
                       j.at("lag_named").get<bool>(), j.at("lag_covered").get<bool>()};
  }
  if (j.contains("dynamics_detected")) r.dynamics_detected = j.at("dynamics_detected").get<bool>();
  if (j.contains("true_share")) r.true_share = NumberOrNaN(j.at("true_share"));
  for (const auto& [name, e] : j.at("reported").items()) {
    r.reported.push_back({EffectFromName(name), NumberOrNaN(e.at("magnitude")), Ci95FromJson(e.at("ci95")),
                          NumberOrNaN(e.at("explained_share")), e.at("selected").get<bool>()});
  }
  return r;
}

Json ClassJson(const SelftestResult& m, const std::string& cname, const SelftestClassStats& s) {
  Json cj = {{"class", cname},
             {"trials", s.n},
             {"gap_detected_rate", s.Rate(s.detected)},
             {"any_compass_alarm_rate", s.Rate(s.any_compass_alarm)},
             {"leftover_reported_rate", s.Rate(s.left_reported)},
             {"verdicts", s.verdicts}};
  if (cname == "one_effect" || cname == "two_effects" || cname == "dynamics_one_effect") {
    cj["top1_rate"] = s.Rate(s.top1);
    Json pe = Json::object();
    for (const auto& [e, v] : s.per_effect) pe[e] = {{"top1", v.hits}, {"trials", v.trials}};
    for (const auto& [e, v] : s.per_effect_coverage) pe[e]["covered"] = v.hits, pe[e]["coverage_trials"] = v.trials;
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
    cj["median_explained_share"] = s.MedianShare();
  }
  if (cname == "two_effects") cj["both_in_effects_rate"] = s.Rate(s.all_in_effects);
  if (cname == "clean") {
    cj["false_alarm_rate"] = m.false_alarm;
    cj["dynamics_false_alarm_rate"] = m.dynamics_false_alarm;
  }
  if (cname == "out_of_library" || cname == "beyond_library") {
    if (m.options.profile == "real") {
      Json pf = Json::object();
      for (const auto& [e, v] : s.per_effect) pf[e] = {{"not_confident", v.hits}, {"trials", v.trials}};
      for (const auto& [e, v] : s.per_form_right) pf[e]["judged_right"] = v.hits;
      for (const auto& [e, v] : s.per_form_named) pf[e]["named_right"] = v.hits;
      for (const auto& [e, v] : s.per_form_lag_named) pf[e]["named_current_lag"] = v.hits;
      for (const auto& [e, v] : s.per_form_lag_covered) pf[e]["lag_covered"] = v.hits;
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

}  // namespace

Json ToJson(const TrialRecord& record) {
  if (const auto* t = std::get_if<ThresholdTrialRecord>(&record)) {
    return Json{{"flagged", t->flagged}, {"magnitude", t->magnitude_uT_per_A}, {"verdict", t->verdict}};
  }
  return ClassRecordJson(std::get<ClassTrialRecord>(record));
}

Result<TrialRecord> TrialRecordFromJson(const Json& j) {
  try {
    if (j.contains("flagged")) {
      return TrialRecord(ThresholdTrialRecord{NumberOrNaN(j.at("magnitude")), j.at("flagged").get<bool>(), j.at("verdict").get<std::string>()});
    }
    return TrialRecord(ClassRecordFromJson(j));
  } catch (const Json::exception& e) {
    return Status::Numerical(std::string("selftest trial record: ") + e.what());
  }
}

Json ToJson(const SelftestResult& result) {
  const SelftestOptions& o = result.options;
  Json j;
  j["schema"] = "hexsim.gap_selftest/1";
  j["profile"] = o.profile;
  j["trials_per_class"] = o.trials;
  j["seed"] = o.seed;
  j["vehicle"] = o.vehicle;
  j["mission"] = o.mission;
  j["channel"] = result.channel;
  j["classes"] = Json::array();
  for (const std::string& c : result.classes) j["classes"].push_back(ClassJson(result, c, result.stats.at(c)));
  j["overall_top1_rate"] = result.overall_top1;
  const double th = result.threshold.value_uT_per_A;
  j["detection_threshold"] = {{"current_hard_iron",
                               {{"uT_per_A", std::isfinite(th) ? Json(th) : Json(nullptr)},
                                {"grid_uT_per_A", result.threshold.grid_uT_per_A},
                                {"flagged_rate", result.threshold.flagged_rate},
                                {"trials_per_magnitude", o.threshold_trials}}}};
  // Every trial's record in trial order, to read a failure from.
  j["trials"] = Json::array();
  for (size_t i = 0; i < result.trials.size(); ++i) {
    Json tj = ToJson(result.trials[i]);
    tj["class"] = result.trial_classes.at(i);
    j["trials"].push_back(std::move(tj));
  }
  j["targets"] = result.targets;
  j["targets_met"] = result.targets_met;
  j["compass_targets_met"] = result.compass_targets_met;
  j["dynamics_targets"] = result.dynamics_targets ? Json(*result.dynamics_targets) : Json(nullptr);
  j["dynamics_targets_met"] = result.dynamics_targets_met;
  return j;
}

}  // namespace hexsim::gap
