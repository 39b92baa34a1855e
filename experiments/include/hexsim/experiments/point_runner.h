// One point flown: the run's setup with its ground calibration attached, the mission, and the run's
// files. `hexsim run` calls it in-process; compare and batch call it inside the forked workers of
// batch's process pool (experiments/run_points.h), so a crashing run cannot take the others down.
#pragma once

#include <string>

#include "hexsim/batch/batch_spec.h"
#include "hexsim/batch/setup_cache.h"
#include "hexsim/common/status.h"
#include "hexsim/sim/simulation.h"

namespace hexsim::experiments {

// Attaches `calibration` (ground_calibration.h) to `setup` and flies the mission. The output's status
// is kNumerical when the run diverged (its log and summary are complete up to then).
Result<sim::RunOutput> FlyPoint(sim::RunSetup setup, const std::string& calibration);

// The same for a batch point, its setup loaded through `cache` (which forked workers inherit).
Result<sim::RunOutput> FlyPoint(const batch::RunPoint& point, batch::SetupCache* cache);

// DIR/log.csv (and log.meta.json beside it).
Status WriteRunLog(const sim::RunOutput& output, const std::string& dir);
// DIR/summary.json, as every command writes it.
Status WriteRunSummary(const sim::RunOutput& output, const std::string& dir);

}  // namespace hexsim::experiments
