// hexsim.summary/1 (CONTRACTS.md) as a type: what one run's summary.json holds. One writer
// (ToJson) and one reader (RunSummaryFromJson); code reads fields, never string keys, so a renamed
// key is a compile error.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hexsim/common/status.h"

namespace hexsim::sim {

// "completed" | "not_completed" | "diverged".
enum class RunStatus { kCompleted, kNotCompleted, kDiverged };
const char* RunStatusName(RunStatus status);

struct MaxRms {
  double max = 0.0;
  double rms = 0.0;
};

struct WaypointArrival {
  int index = 0;
  double arrival_error_m = 0.0;  // distance from the waypoint when it was declared reached
  double arrival_time_s = 0.0;
};

struct RunSummary {
  RunStatus status = RunStatus::kNotCompleted;
  std::string reason;  // why not completed / what diverged; empty when completed
  std::string mission, vehicle, world, calibration, estimator;
  uint64_t seed = 0;
  double duration_s = 0.0;              // simulated time flown
  double distance_m = 0.0;              // path length of the true track
  MaxRms cross_track_m;                 // from the active leg of the planned path
  MaxRms yaw_error_deg;                 // estimated − true yaw, wrapped to ±180, on mission legs
  MaxRms yaw_error_all_deg;             // the same over the whole flight
  double energy_Wh = 0.0;               // battery energy drawn
  double current_max_A = 0.0, current_mean_A = 0.0;  // battery current (JSON: current_A {max, mean})
  // Time with any ESC at its current limit / the battery at its limit (JSON: current_limited_s
  // {esc, battery}; a summary written before the limits existed reads as 0).
  double current_limited_esc_s = 0.0, current_limited_battery_s = 0.0;
  std::optional<double> mission_time_s;  // takeoff to landing; none when it never landed
  std::vector<WaypointArrival> waypoints;
  double wall_s = 0.0;                  // wall-clock time of the run (not reproducible)
  std::string version;
};

// summary.json's document ({"schema": "hexsim.summary/1", ...}).
nlohmann::json ToJson(const RunSummary& summary);
// Reads a summary.json document; BadInput naming `source` and the key when a key is missing or has
// the wrong type.
Result<RunSummary> RunSummaryFromJson(const nlohmann::json& document, const std::string& source);

}  // namespace hexsim::sim
