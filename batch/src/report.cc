#include "hexsim/batch/report.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace hexsim::batch {

using nlohmann::json;

double StudentT975(size_t dof) {
  // t_{0.975, ν} for ν = 1..30 (standard tables); beyond that the Cornish–Fisher expansion
  // t ≈ z + (z³ + z)/(4ν) + (5z⁵ + 16z³ + 3z)/(96ν²), z = 1.959964.
  static const double kTable[30] = {12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228,
                                    2.201,  2.179, 2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086,
                                    2.080,  2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042};
  if (dof >= 1 && dof <= 30) return kTable[dof - 1];
  const double z = 1.959964, v = static_cast<double>(std::max<size_t>(dof, 1));
  return z + (z * z * z + z) / (4 * v) + (5 * std::pow(z, 5) + 16 * z * z * z + 3 * z) / (96 * v * v);
}

MetricStats ComputeStats(const std::vector<double>& values) {
  MetricStats s;
  s.n = values.size();
  if (s.n == 0) return s;
  double sum = 0;
  for (double v : values) sum += v;
  s.mean = sum / static_cast<double>(s.n);
  if (s.n >= 2) {
    double ss = 0;
    for (double v : values) ss += (v - s.mean) * (v - s.mean);
    const double sd = std::sqrt(ss / static_cast<double>(s.n - 1));
    const double half = StudentT975(s.n - 1) * sd / std::sqrt(static_cast<double>(s.n));
    s.std = sd;
    s.ci95_lo = s.mean - half;
    s.ci95_hi = s.mean + half;
  }
  return s;
}

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
    if (IsFailure(k.row->status)) continue;
    for (const auto& [name, v] : k.row->metrics) {
      if (v) values.back()[name].push_back(*v);
    }
  }
  for (size_t i = 0; i < groups.size(); ++i) {
    for (const auto& m : MetricColumns()) {
      groups[i].metrics[m.column] = ComputeStats(values[i][m.column]);
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
                       {"ci95", s.ci95_lo ? json::array({*s.ci95_lo, *s.ci95_hi}) : json(nullptr)}};
    }
    out["groups"].push_back(
        {{"label", g.label}, {"params", g.params}, {"runs", g.runs}, {"status", g.status_counts}, {"metrics", metrics}});
  }
  out["runs"] = total;
  return out;
}

std::string ReportTable(const std::vector<GroupReport>& groups) {
  std::string out;
  for (const auto& g : groups) {
    std::string status;
    for (const auto& [s, n] : g.status_counts) status += fmt::format("{}{} {}", status.empty() ? "" : ", ", n, s);
    out += fmt::format("{}  ({} runs: {})\n", g.label, g.runs, status);
    out += fmt::format("  {:<20} {:>4} {:>12} {:>12} {:>27}\n", "metric", "n", "mean", "std", "95% CI of mean");
    for (const auto& m : MetricColumns()) {
      const MetricStats& s = g.metrics.at(m.column);
      if (s.n == 0) {
        out += fmt::format("  {:<20} {:>4} {:>12}\n", m.column, 0, "-");
        continue;
      }
      out += fmt::format("  {:<20} {:>4} {:>12.4g} {:>12} {:>27}\n", m.column, s.n, s.mean,
                         s.std ? fmt::format("{:.4g}", *s.std) : "-",
                         s.ci95_lo ? fmt::format("[{:.4g}, {:.4g}]", *s.ci95_lo, *s.ci95_hi) : "-");
    }
  }
  return out;
}

}  // namespace hexsim::batch
