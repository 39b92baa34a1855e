#include "compare_stats.h"

#include <cmath>

#include <fmt/format.h>

#include "hexsim/common/statistics.h"

namespace hexsim::app {

const std::vector<std::string>& SummaryFigures() {
  static const std::vector<std::string> k = {"yaw_error_deg.max", "yaw_error_deg.rms", "cross_track_m.max",
                                             "cross_track_m.rms", "energy_Wh",         "mission_time_s",
                                             "distance_m",        "current_A.mean",    "current_A.max"};
  return k;
}

namespace {
bool Lookup(const nlohmann::json& s, const std::string& path, double* v) {
  const nlohmann::json* j = &s;
  size_t start = 0;
  while (true) {
    const size_t dot = path.find('.', start);
    const std::string key = path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (!j->is_object() || !j->contains(key)) return false;
    j = &(*j)[key];
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  if (!j->is_number()) return false;
  *v = j->get<double>();
  return std::isfinite(*v);
}
}  // namespace

nlohmann::json GroupMetrics(const std::vector<nlohmann::json>& summaries) {
  nlohmann::json m = nlohmann::json::object();
  for (const auto& f : SummaryFigures()) {
    std::vector<double> x;
    for (const auto& s : summaries) {
      double v = 0;
      if (Lookup(s, f, &v)) x.push_back(v);
    }
    if (x.empty()) continue;
    const SampleStats st = Summarize(x);
    const double sd = st.std.value_or(0.0);
    m[f] = {{"mean", st.mean}, {"std", sd}, {"ci95", {st.ci95_lo.value_or(st.mean), st.ci95_hi.value_or(st.mean)}}, {"n", x.size()}};
  }
  return m;
}

std::string CompareTable(const nlohmann::json& c) {
  std::string out = fmt::format("{} on {} ({}), mean ± std over seeds\n", c.value("mission", ""), c.value("vehicle", ""),
                                c.value("world", ""));
  const std::vector<std::pair<std::string, std::string>> cols = {{"yaw_error_deg.max", "yaw max deg"},
                                                                 {"yaw_error_deg.rms", "yaw rms deg"},
                                                                 {"cross_track_m.max", "xtrack max m"},
                                                                 {"cross_track_m.rms", "xtrack rms m"},
                                                                 {"energy_Wh", "energy Wh"}};
  out += fmt::format("{:<18}{:>4}", "calibration", "n");
  for (const auto& [k, name] : cols) out += fmt::format("{:>18}", name);
  out += "\n";
  for (const auto& g : c["groups"]) {
    out += fmt::format("{:<18}{:>4}", g["calibration"].get<std::string>(), g["n"].get<int>());
    for (const auto& [k, name] : cols) {
      if (g["metrics"].contains(k)) {
        out += fmt::format("{:>18}", fmt::format("{:.2f} ± {:.2f}", g["metrics"][k]["mean"].get<double>(),
                                                 g["metrics"][k]["std"].get<double>()));
      } else {
        out += fmt::format("{:>18}", "-");
      }
    }
    out += "\n";
  }
  if (c.contains("heading_error")) {
    const auto& he = c["heading_error"];
    out += "\nturntable heading error, max |error| over a level turn (deg) [paper's Table 1]\n";
    out += fmt::format("{:<18}", "calibration");
    for (const auto& u : he["control_u"]) out += fmt::format("{:>10}", fmt::format("u={:g}", u.get<double>()));
    out += "\n";
    for (const auto& r : he["rows"]) {
      out += fmt::format("{:<18}", r["name"].get<std::string>());
      for (const auto& v : r["max_deg"]) out += fmt::format("{:>10.2f}", v.get<double>());
      out += "\n";
    }
    out += "paper: uncorrected 12.5/13.3/14.3, traditional 2.5/5.0/7.6, adaptive 2.4/2.5/2.6\n";
  }
  return out;
}

}  // namespace hexsim::app
