// The comparison experiment (`hexsim compare`): one mission flown with each calibration over several
// seeds, each run in a forked worker of batch's process pool; Table 1 for the same calibrations,
// learnt from the same ground session as the first seed's flights; and, for the report, the evidence
// behind every figure, computed here once.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexsim/common/status.h"
#include "hexsim/experiments/comparison.h"
#include "hexsim/experiments/table1.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/sim/run_config.h"

namespace hexsim::experiments {

struct CompareOptions {
  sim::RunRequest request;                // mission, vehicle, world, estimator, first seed, duration, --set
  std::vector<std::string> calibrations;  // "none", method names or calib.yaml paths
  int seeds = 3;                          // seeds request.seed … request.seed + seeds − 1
  int jobs = 1;                           // worker processes
  bool evidence = true;                   // also gather what the report draws
  Status IsValid() const;
};

// A calibration's first-seed flight, as its worker flew it (batch::RunResult::log).
struct FlownRun {
  std::string calibration;
  uint64_t seed = 0;
  logs::FlightLog log;
};

// What the report draws, exactly as the comparison used it.
struct CompareEvidence {
  GroundSessionFits ground_fits;        // the first seed's ground session, per control amount (Figs. 3–4)
  std::vector<HeadingCurves> heading;   // Table 1's curves, per calibration (Figs. 5–7)
  std::vector<FlownRun> first_flights;  // per calibration, its first seed (Figs. 8–9, yaw, current)
  // The mission's planned path from where the first flight started (none without a position log).
  std::optional<std::vector<Eigen::Vector3d>> planned_path_N_m;
};

struct CompareResult {
  Comparison comparison;
  CompareEvidence evidence;  // empty unless options.evidence
};

// Flies every run into out_dir/<calibration>/seed_<n>/ (log.csv, log.meta.json, summary.json) and
// prints one line per finished run on stderr. BadInput before anything is flown for bad options or
// files; a run that fails or crashes fails the comparison.
Result<CompareResult> RunComparison(const CompareOptions& options, const std::string& out_dir);

}  // namespace hexsim::experiments
