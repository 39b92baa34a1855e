// The comparison of calibrations (hexsim.comparison/1, CONTRACTS.md): every run (calibration ×
// seed) with its summary, the group statistics per calibration, and the paper's Table 1 rows for
// the same calibrations. Typed here; ToJson writes the contract's document.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hexsim/common/statistics.h"
#include "hexsim/sim/run_summary.h"

namespace hexsim::experiments {

struct ComparisonRun {
  std::string calibration;
  uint64_t seed = 0;
  sim::RunSummary summary;
  std::string dir;         // where the run's log.csv and summary.json are, relative to the output directory
};

// A figure compared across runs, named by its path in summary.json ("key" or "key.sub"); none when
// the run has no such value (mission_time_s of a run that never landed) or it is not finite.
struct SummaryFigure {
  const char* path;
  std::optional<double> (*value)(const sim::RunSummary&);
};
const std::vector<SummaryFigure>& SummaryFigures();

struct ComparisonGroup {
  std::string calibration;
  size_t n = 0;                                // runs in the group
  std::map<std::string, SampleStats> metrics;  // by SummaryFigures() path, over the runs that have it
};
// {figure: statistics} over the summaries that have the figure (finite).
std::map<std::string, SampleStats> GroupMetrics(const std::vector<sim::RunSummary>& summaries);

// Table 1: max and RMS |heading error| over one level turn per control amount (hexsim.heading_error/1).
struct HeadingErrorRow {
  std::string name;    // "uncorrected" for "none"
  std::string method;  // the calibration
  std::vector<double> max_deg, rms_deg, current_A;  // one per control amount
};
struct HeadingErrorTable {
  std::vector<double> control_u;
  std::vector<HeadingErrorRow> rows;
};

struct Comparison {
  std::string mission, vehicle, world, estimator;
  std::vector<ComparisonRun> runs;       // calibrations in order, seeds ascending within each
  std::vector<ComparisonGroup> groups;   // one per calibration, in order
  HeadingErrorTable heading_error;
};

// hexsim.comparison/1 (with heading_error: hexsim.heading_error/1).
nlohmann::json ToJson(const Comparison& comparison);
// The comparison as a text table (calibration × figure, mean ± std) and the Table 1 rows.
std::string ComparisonTable(const Comparison& comparison);

}  // namespace hexsim::experiments
