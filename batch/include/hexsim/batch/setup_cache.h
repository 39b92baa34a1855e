// Loaded run setups shared across seeds. Parsing the mission, vehicle and world YAML is about half
// of a short run's cost; the batch parent loads each distinct configuration once (it validates them
// anyway) and its forked workers inherit the result.
#pragma once

#include <map>
#include <string>

#include "hexsim/batch/batch_spec.h"
#include "hexsim/common/status.h"
#include "hexsim/sim/run_config.h"

namespace hexsim::batch {

// The sim::RunRequest for a point (the calibration is attached separately).
sim::RunRequest RequestFor(const RunPoint& point);

class SetupCache {
 public:
  // At most `max_entries` configurations are kept; beyond that, Get loads every time.
  explicit SetupCache(size_t max_entries = 256) : max_entries_(max_entries) {}

  // The same as sim::LoadRunSetup(RequestFor(point)): the setup of the point's parameters without
  // seed and calibration, loaded once, with the seed then set (LoadRunSetup uses the seed only for
  // options.seed; batch_test checks the two agree).
  Result<sim::RunSetup> Get(const RunPoint& point);
  size_t size() const { return cache_.size(); }

  // The cache key: the canonical parameters without seed and calibration.
  static std::string Key(const RunPoint& point);

 private:
  size_t max_entries_;
  std::map<std::string, sim::RunSetup> cache_;
};

}  // namespace hexsim::batch
