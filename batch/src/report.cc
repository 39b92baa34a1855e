#include "hexsim/batch/report.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace hexsim::batch {

using nlohmann::json;

namespace {

std::string ValueText(const json& v) { return v.is_string() ? v.get<std::string>() : v.dump(); }

std::string GroupLabel(const json& params) {
  std::string label = fmt::format("{} {} {} {}", params.value("mission", ""), params.value("vehicle", ""),
                                  params.value("world", ""), params.value("calibration", ""));
  const std::string est = params.value("estimator", "");
  if (!est.empty()) label += " " + est;
  if (params.contains("duration_s") && params["duration_s"] != json(0)) label += " " + params["duration_s"].dump() + "s";
  if (params.contains("set")) {
    for (const auto& [k, v] : params["set"].items()) label += " " + k + "=" + ValueText(v);
  }
  return label;
}

}  // namespace

std::vector<GroupReport> AggregateRuns(const std::vector<RunRow>& rows) {
  struct Keyed {
    std::string label;
    json params;
    const RunRow* row;
  };
  std::vector<Keyed> keyed;
  for (const auto& r : rows) {
    json p = json::parse(r.params_json, nullptr, /*allow_exceptions=*/false);
    if (p.is_discarded() || !p.is_object()) p = json{{"mission", r.mission}, {"vehicle", r.vehicle}};
    p.erase("seed");
    keyed.push_back({GroupLabel(p), p, &r});
  }
  std::stable_sort(keyed.begin(), keyed.end(), [](const Keyed& a, const Keyed& b) {
    return a.label != b.label ? a.label < b.label : a.row->seed < b.row->seed;
  });
  std::vector<GroupReport> groups;
  std::vector<std::map<std::string, std::vector<double>>> values;
  for (const auto& k : keyed) {
    if (groups.empty() || groups.back().label != k.label || groups.back().params != k.params) {
      groups.push_back({});
      groups.back().label = k.label;
      groups.back().params = k.params;
      values.emplace_back();
    }
    GroupReport& g = groups.back();
    ++g.runs;
    ++g.status_counts[k.row->status];
    if (k.row->status != "completed") {
      g.unfinished.push_back({k.row->run_id, k.row->seed, k.row->status, k.row->reason});
      continue;
    }
    ++g.finished;
    for (const auto& [name, v] : k.row->metrics) {
      if (v) values.back()[name].push_back(*v);
    }
  }
  for (size_t i = 0; i < groups.size(); ++i) {
    for (const auto& m : MetricColumns()) {
      // Non-negative figures (all but the currents) keep their interval at or above 0.
      const bool signed_figure = std::string(m.column).rfind("current_", 0) == 0;
      groups[i].metrics[m.column] =
          signed_figure ? Summarize(values[i][m.column]) : SummarizeNonNegative(values[i][m.column]);
      groups[i].values[m.column] = values[i][m.column];
    }
  }
  return groups;
}

json ReportJson(const std::vector<GroupReport>& groups) {
  auto opt = [](const std::optional<double>& v) { return v ? json(*v) : json(nullptr); };
  json out = {{"schema", "hexsim.batch_report/1"}, {"groups", json::array()}};
  size_t total = 0;
  for (const auto& g : groups) {
    total += g.runs;
    json metrics = json::object();
    for (const auto& [name, s] : g.metrics) {
      metrics[name] = {{"n", s.n},
                       {"mean", s.n ? json(s.mean) : json(nullptr)},
                       {"std", opt(s.std)},
                       {"ci95", s.ci95_lo ? json::array({*s.ci95_lo, *s.ci95_hi}) : json(nullptr)},
                       {"ci95_clipped", s.ci95_clipped}};
    }
    json unfinished = json::array();
    for (const auto& u : g.unfinished) {
      unfinished.push_back({{"run_id", u.run_id}, {"seed", u.seed}, {"status", u.status}, {"reason", u.reason}});
    }
    out["groups"].push_back({{"label", g.label},
                             {"params", g.params},
                             {"runs", g.runs},
                             {"finished", g.finished},
                             {"status", g.status_counts},
                             {"metrics", metrics},
                             {"unfinished", unfinished}});
  }
  out["runs"] = total;
  return out;
}

}  // namespace hexsim::batch
