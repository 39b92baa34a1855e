// Loading one run's configuration from the world files and the command line: mission, vehicle
// (with its `control:` and `nav:` sections), world, simulator options, and `--set KEY=VALUE`
// overrides (mission.*, vehicle.*, world.*, control.*, nav.*, sim.*).
#pragma once

#include <string>
#include <vector>

#include "hexsim/common/status.h"
#include "hexsim/sim/simulation.h"

namespace hexsim::sim {

struct RunRequest {
  std::string mission = "square";
  std::string vehicle = "default_hex";
  std::string world = "default";
  std::string estimator;             // empty: sim.estimator (default eskf)
  uint64_t seed = 1;
  double duration_s = 0.0;
  std::vector<std::string> sets;     // KEY=VALUE
  bool allow_field_extrapolation = false;
};

// Resolves names under worlds/, reads and validates every file, applies the overrides.
// Any problem is kBadInput naming the file, line and field. The compensator is left empty.
Result<RunSetup> LoadRunSetup(const RunRequest& request);

}  // namespace hexsim::sim
