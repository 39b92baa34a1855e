#include "hexsim/experiments/comparison.h"

#include <cmath>

#include <fmt/format.h>

namespace hexsim::experiments {

using nlohmann::json;

const std::vector<SummaryFigure>& SummaryFigures() {
  using S = sim::RunSummary;
  static const std::vector<SummaryFigure> k = {
      {"yaw_error_deg.max", [](const S& s) -> std::optional<double> { return s.yaw_error_deg.max; }},
      {"yaw_error_deg.rms", [](const S& s) -> std::optional<double> { return s.yaw_error_deg.rms; }},
      {"cross_track_m.max", [](const S& s) -> std::optional<double> { return s.cross_track_m.max; }},
      {"cross_track_m.rms", [](const S& s) -> std::optional<double> { return s.cross_track_m.rms; }},
      {"energy_Wh", [](const S& s) -> std::optional<double> { return s.energy_Wh; }},
      {"mission_time_s", [](const S& s) { return s.mission_time_s; }},
      {"distance_m", [](const S& s) -> std::optional<double> { return s.distance_m; }},
      {"current_A.mean", [](const S& s) -> std::optional<double> { return s.current_mean_A; }},
      {"current_A.max", [](const S& s) -> std::optional<double> { return s.current_max_A; }}};
  return k;
}

std::map<std::string, SampleStats> GroupMetrics(const std::vector<sim::RunSummary>& summaries) {
  std::map<std::string, SampleStats> m;
  for (const auto& f : SummaryFigures()) {
    std::vector<double> x;
    for (const auto& s : summaries) {
      const std::optional<double> v = f.value(s);
      if (v && std::isfinite(*v)) x.push_back(*v);
    }
    // Every figure but the current is a magnitude, a length, an energy or a time: its interval stays
    // at or above 0 (SummarizeNonNegative says when it clipped).
    if (!x.empty()) m[f.path] = std::string(f.path).rfind("current_A", 0) == 0 ? Summarize(x) : SummarizeNonNegative(x);
  }
  return m;
}

json ToJson(const Comparison& c) {
  json cmp;
  cmp["schema"] = "hexsim.comparison/1";
  cmp["mission"] = c.mission;
  cmp["vehicle"] = c.vehicle;
  cmp["world"] = c.world;
  cmp["estimator"] = c.estimator;
  cmp["runs"] = json::array();
  for (const auto& r : c.runs) cmp["runs"].push_back({{"calibration", r.calibration}, {"seed", r.seed}, {"summary", sim::ToJson(r.summary)}});
  cmp["groups"] = json::array();
  for (const auto& g : c.groups) {
    json metrics = json::object();
    for (const auto& [f, s] : g.metrics) {
      // One run: no spread; the interval collapses onto the mean.
      metrics[f] = {{"mean", s.mean},
                    {"std", s.std.value_or(0.0)},
                    {"ci95", {s.ci95_lo.value_or(s.mean), s.ci95_hi.value_or(s.mean)}},
                    {"ci95_clipped", s.ci95_clipped},
                    {"n", s.n}};
    }
    cmp["groups"].push_back({{"calibration", g.calibration}, {"n", g.n}, {"metrics", metrics}});
  }
  json he;
  he["schema"] = "hexsim.heading_error/1";
  he["control_u"] = c.heading_error.control_u;
  he["rows"] = json::array();
  for (const auto& r : c.heading_error.rows) {
    he["rows"].push_back({{"name", r.name}, {"method", r.method}, {"max_deg", r.max_deg}, {"rms_deg", r.rms_deg},
                          {"current_A", r.current_A}});
  }
  cmp["heading_error"] = he;
  return cmp;
}

std::string ComparisonTable(const Comparison& c) {
  std::string out = fmt::format("{} on {} ({}), mean ± std over seeds\n", c.mission, c.vehicle, c.world);
  const std::vector<std::pair<std::string, std::string>> cols = {{"yaw_error_deg.max", "yaw max deg"},
                                                                 {"yaw_error_deg.rms", "yaw rms deg"},
                                                                 {"cross_track_m.max", "xtrack max m"},
                                                                 {"cross_track_m.rms", "xtrack rms m"},
                                                                 {"energy_Wh", "energy Wh"}};
  out += fmt::format("{:<18}{:>4}", "calibration", "n");
  for (const auto& [k, name] : cols) out += fmt::format("{:>18}", name);
  out += "\n";
  for (const auto& g : c.groups) {
    out += fmt::format("{:<18}{:>4}", g.calibration, g.n);
    for (const auto& [k, name] : cols) {
      const auto it = g.metrics.find(k);
      if (it != g.metrics.end()) {
        out += fmt::format("{:>18}", fmt::format("{:.2f} ± {:.2f}", it->second.mean, it->second.std.value_or(0.0)));
      } else {
        out += fmt::format("{:>18}", "-");
      }
    }
    out += "\n";
  }
  const HeadingErrorTable& he = c.heading_error;
  out += "\nturntable heading error, max |error| over a level turn (deg) [paper's Table 1]\n";
  out += fmt::format("{:<18}", "calibration");
  for (double u : he.control_u) out += fmt::format("{:>10}", fmt::format("u={:g}", u));
  out += "\n";
  for (const auto& r : he.rows) {
    out += fmt::format("{:<18}", r.name);
    for (double v : r.max_deg) out += fmt::format("{:>10.2f}", v);
    out += "\n";
  }
  out += "paper: uncorrected 12.5/13.3/14.3, traditional 2.5/5.0/7.6, adaptive 2.4/2.5/2.6\n";
  return out;
}

}  // namespace hexsim::experiments
