#include "hexsim/reports/headline.h"

#include <algorithm>
#include <cmath>
#include <map>

#include <fmt/format.h>

namespace hexsim::reports {

namespace {

constexpr const char* kYawMax = "yaw_error_deg.max";
constexpr const char* kCrossRms = "cross_track_m.rms";

// "2.9° [0.4, 5.5]": the mean and its 95 % interval; a lower end clipped at zero is marked "*".
std::string WithInterval(const SampleStats& s, const char* unit, int decimals) {
  std::string text = fmt::format("{:.{}f}{}", s.mean, decimals, unit);
  if (s.ci95_lo && s.ci95_hi) {
    text += fmt::format(" [{:.{}f}{}, {:.{}f}]", *s.ci95_lo, decimals, s.ci95_clipped ? "*" : "", *s.ci95_hi, decimals);
  }
  return text;
}

bool Overlap(const SampleStats& a, const SampleStats& b) {
  if (!a.ci95_lo || !b.ci95_lo) return true;  // without intervals nothing is separated
  return *a.ci95_lo <= *b.ci95_hi && *b.ci95_lo <= *a.ci95_hi;
}

const experiments::ComparisonGroup* Find(const experiments::Comparison& c, const std::string& calibration) {
  for (const auto& g : c.groups) {
    if (g.calibration == calibration) return &g;
  }
  return nullptr;
}

bool Has(const experiments::ComparisonGroup& g, const char* figure) { return g.metrics.count(figure) > 0; }

// "from X with no calibration to Y": one figure of `from` against `to`.
std::string FromTo(const experiments::ComparisonGroup& from, const experiments::ComparisonGroup& to,
                   const char* figure, const char* unit, int decimals) {
  return fmt::format("from {} to {}", WithInterval(from.metrics.at(figure), unit, decimals),
                     WithInterval(to.metrics.at(figure), unit, decimals));
}

std::string Name(const std::string& calibration) {
  return calibration == "none" ? std::string("no calibration") : calibration;
}

// "(intervals apart)" or "(intervals overlap: these seeds do not separate them)".
std::string Separation(const SampleStats& a, const SampleStats& b) {
  return Overlap(a, b) ? " (the intervals overlap: these seeds do not separate them)" : " (the intervals are apart)";
}

// "Against none, adaptive cuts the maximum yaw error from … to … (…) and the cross-track RMS …".
std::string Against(const experiments::ComparisonGroup& best, const experiments::ComparisonGroup& other) {
  const SampleStats &by = best.metrics.at(kYawMax), &oy = other.metrics.at(kYawMax);
  std::string s = fmt::format("Against {}, {} {} the maximum yaw error {}{}", Name(other.calibration), best.calibration,
                              by.mean < oy.mean ? "cuts" : "does not cut", FromTo(other, best, kYawMax, "°", 1),
                              Separation(by, oy));
  if (Has(best, kCrossRms) && Has(other, kCrossRms)) {
    const SampleStats &bx = best.metrics.at(kCrossRms), &ox = other.metrics.at(kCrossRms);
    s += fmt::format(", and {} the cross-track RMS {}{}", bx.mean < ox.mean ? "cuts" : "does not cut",
                     FromTo(other, best, kCrossRms, " m", 2), Separation(bx, ox));
  }
  return s + ".";
}

}  // namespace

std::vector<std::string> CompareHeadline(const experiments::Comparison& c) {
  std::vector<std::string> out;
  const experiments::ComparisonGroup* best = nullptr;
  size_t seeds = 0;
  for (const auto& g : c.groups) {
    seeds = std::max(seeds, g.n);
    if (g.calibration == "none" || !Has(g, kYawMax)) continue;
    if (!best || g.metrics.at(kYawMax).mean < best->metrics.at(kYawMax).mean) best = &g;
  }
  out.push_back(fmt::format("{} flown by {} ({} estimate), {} calibration{} × {} seed{}.", c.mission, c.vehicle,
                            c.estimator.empty() ? "eskf" : c.estimator, c.groups.size(), c.groups.size() == 1 ? "" : "s",
                            seeds, seeds == 1 ? "" : "s"));
  if (!best) {
    out.emplace_back("No calibrated run reports a yaw error: nothing to compare.");
    return out;
  }
  out.push_back(fmt::format("Lowest mean maximum yaw error: {}, {}{}.", best->calibration,
                            WithInterval(best->metrics.at(kYawMax), "°", 1),
                            Has(*best, kCrossRms)
                                ? fmt::format(", cross-track RMS {}", WithInterval(best->metrics.at(kCrossRms), " m", 2))
                                : std::string()));
  for (const char* other : {"none", "traditional"}) {
    const experiments::ComparisonGroup* g = Find(c, other);
    if (g && g != best && Has(*g, kYawMax)) out.push_back(Against(*best, *g));
  }
  bool clipped = false;
  for (const auto& g : c.groups) {
    for (const auto& [k, s] : g.metrics) clipped = clipped || s.ci95_clipped;
  }
  out.push_back(fmt::format("Means over seeds with their 95 % intervals (Student t){}.",
                            clipped ? "; * marks a lower end clipped at 0, which no error magnitude goes below" : ""));
  return out;
}

std::vector<std::string> BatchHeadline(const std::vector<batch::GroupReport>& groups) {
  std::vector<std::string> out;
  size_t runs = 0;
  std::map<std::string, size_t> status;
  for (const auto& g : groups) {
    runs += g.runs;
    for (const auto& [s, n] : g.status_counts) status[s] += n;
  }
  std::string outcome;
  for (const auto& [s, n] : status) outcome += fmt::format("{}{} {}", outcome.empty() ? "" : ", ", n, s);
  out.push_back(fmt::format("{} run{} in {} group{}: {}.", runs, runs == 1 ? "" : "s", groups.size(),
                            groups.size() == 1 ? "" : "s", outcome.empty() ? "none finished" : outcome));
  const char* metric = "cross_track_rms_m";
  const batch::GroupReport* lo = nullptr;
  const batch::GroupReport* hi = nullptr;
  for (const auto& g : groups) {
    auto it = g.metrics.find(metric);
    if (it == g.metrics.end() || it->second.n == 0) continue;
    if (!lo || it->second.mean < lo->metrics.at(metric).mean) lo = &g;
    if (!hi || it->second.mean > hi->metrics.at(metric).mean) hi = &g;
  }
  if (!lo) return out;
  if (lo->metrics.at(metric).mean == hi->metrics.at(metric).mean) {
    size_t with_data = 0;
    for (const auto& g : groups) with_data += g.metrics.count(metric) && g.metrics.at(metric).n > 0 ? 1 : 0;
    out.push_back(fmt::format("Cross-track RMS {}{}.", WithInterval(lo->metrics.at(metric), " m", 2),
                              with_data > 1 ? fmt::format(", the same in all {} groups", with_data) : std::string()));
  } else {
    out.push_back(fmt::format("Cross-track RMS is lowest in {} ({}) and highest in {} ({}){}.", lo->label,
                              WithInterval(lo->metrics.at(metric), " m", 2), hi->label,
                              WithInterval(hi->metrics.at(metric), " m", 2),
                              Overlap(lo->metrics.at(metric), hi->metrics.at(metric))
                                  ? "; their intervals overlap, so the sweep does not separate them"
                                  : ""));
  }
  out.emplace_back("Means over seeds with their 95 % intervals (Student t); * marks a lower end clipped at 0.");
  return out;
}

}  // namespace hexsim::reports
