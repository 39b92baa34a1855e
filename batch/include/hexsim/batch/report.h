// `hexsim batch-report`: runs grouped by their parameters except the seed (replicates of one
// configuration), each summary figure as mean, sample standard deviation and a 95 % confidence
// interval of the mean (Student t, n − 1 degrees of freedom). Figures are taken from runs that
// finished (status completed) only: a run that hit the time cap (not_completed) flew on, burning
// energy, and diverged/failed/crashed runs have no figures; those are counted and listed, not averaged.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hexsim/batch/results_db.h"
#include "hexsim/common/statistics.h"

namespace hexsim::batch {

// n, mean, sample std and the 95 % t interval of a metric (common/statistics.h: Summarize).
using MetricStats = hexsim::SampleStats;

// A run of a group that did not finish, listed beside the group's figures.
struct UnfinishedRun {
  std::string run_id;
  uint64_t seed = 0;
  std::string status;  // not_completed, diverged, failed, crashed, timeout
  std::string reason;
};

struct GroupReport {
  std::string label;          // "square paper_hex changchun none eskf control.rate.roll.kp=0.12"
  nlohmann::json params;      // the run parameters without the seed
  size_t runs = 0;
  std::map<std::string, size_t> status_counts;
  size_t finished = 0;                  // runs that completed: the figures are over these
  std::vector<UnfinishedRun> unfinished;  // the others, in seed order
  std::map<std::string, MetricStats> metrics;  // by MetricColumns() name
  std::map<std::string, std::vector<double>> values;  // the figures averaged, in seed order
};

// Groups in order of first appearance when rows are sorted by (label, seed).
std::vector<GroupReport> AggregateRuns(const std::vector<RunRow>& rows);

// hexsim.batch_report/1: {schema, runs, groups: [{label, params, runs, finished, status,
// metrics: {m: {n, mean, std, ci95}}, unfinished: [{run_id, seed, status, reason}]}]}
nlohmann::json ReportJson(const std::vector<GroupReport>& groups);
// The text table and the figure: reports/batch_report.h.

}  // namespace hexsim::batch
