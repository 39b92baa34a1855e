// Pieces the calibrate paths (calibrate.cc, calibrate_flight.cc) share.
#pragma once

#include <algorithm>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "hexsim/magnetics/field_calibration.h"

namespace hexsim::magnetics::internal {

inline nlohmann::json Vec(const Eigen::Vector3d& v) { return nlohmann::json::array({v(0), v(1), v(2)}); }

// The sample-direction coverage about the median raw norm.
inline Coverage CoverageAboutMedianNorm(const std::vector<Eigen::Vector3d>& raw_uT) {
  std::vector<double> norms;
  norms.reserve(raw_uT.size());
  for (const auto& b : raw_uT) norms.push_back(b.norm());
  std::nth_element(norms.begin(), norms.begin() + static_cast<std::ptrdiff_t>(norms.size() / 2), norms.end());
  return ComputeCoverage(raw_uT, norms[norms.size() / 2]);
}

}  // namespace hexsim::magnetics::internal
