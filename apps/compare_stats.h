// Aggregates of run summaries: mean, standard deviation and a 95 % confidence interval of the mean
// (Student's t) for each figure of hexsim.summary/1.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace hexsim::app {

// The summary figures compared, as "key" or "key.sub" paths into summary.json.
const std::vector<std::string>& SummaryFigures();
// {figure: {mean, std, ci95: [lo, hi]}} over the summaries that have the figure.
nlohmann::json GroupMetrics(const std::vector<nlohmann::json>& summaries);
// The comparison as a text table (method × metric, mean ± std) plus the heading-error table.
std::string CompareTable(const nlohmann::json& comparison);

}  // namespace hexsim::app
