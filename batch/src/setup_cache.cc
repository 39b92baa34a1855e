#include "hexsim/batch/setup_cache.h"

namespace hexsim::batch {

sim::RunRequest RequestFor(const RunPoint& p) {
  sim::RunRequest req;
  req.mission = p.mission;
  req.vehicle = p.vehicle;
  req.world = p.world;
  req.estimator = p.estimator;
  req.seed = p.seed;
  req.duration_s = p.duration_s;
  req.sets = p.SetAssignments();
  return req;
}

std::string SetupCache::Key(const RunPoint& point) {
  nlohmann::json params = point.Params();
  params.erase("seed");
  params.erase("calibration");
  return params.dump();
}

Result<sim::RunSetup> SetupCache::Get(const RunPoint& point) {
  const std::string key = Key(point);
  auto it = cache_.find(key);
  if (it == cache_.end()) {
    auto loaded = sim::LoadRunSetup(RequestFor(point));
    if (!loaded.ok()) return loaded.status();
    if (cache_.size() >= max_entries_) return loaded;
    it = cache_.emplace(key, std::move(*loaded)).first;
  }
  sim::RunSetup setup = it->second;
  setup.options.seed = point.seed;
  return setup;
}

}  // namespace hexsim::batch
