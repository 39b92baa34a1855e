// Missions: a list of items (takeoff, waypoint, hold, payload, land) with mission-level defaults.
//
//   name: square                       # optional
//   speed_mps: 5                       # default leg speed
//   acceptance_radius_m: 1.0
//   yaw_mode: travel                   # travel (face the direction of travel) | hold (keep heading)
//   payload_kg: 0                      # payload attached at the start (optional)
//   wind: {mean_N_mps: [3, 0, 0], gust_std_mps: 0.5}   # optional override of the world's wind
//   items:                             # one map per item, `type` first
//     - {type: takeoff, alt_m: 10}
//     - {type: waypoint, p_N_m: [20, 0, -10], speed_mps: 5, hold_s: 0, yaw_deg: 90}
//     - {type: waypoint, lat_deg: 43.8801, lon_deg: 125.3500, alt_m: 10}   # alt_m above home
//     - {type: hold, duration_s: 5}
//     - {type: payload, action: release, mass_kg: 2.0}
//     - {type: land}
// ParseMission (hexsim::control_io, hexsim/control/control_io.h) reads this document.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexsim/common/status.h"

namespace hexsim::control {

// A geodetic point on WGS-84: latitude, longitude, height above the ellipsoid.
struct GeoPoint {
  double lat_deg = 0.0;
  double lon_deg = 0.0;
  double alt_m = 0.0;
};

// NED position of `point` relative to `origin` in the origin's local tangent plane (exact
// geodetic → ECEF → NED rotation on WGS-84; D includes the Earth's curvature below the plane).
Eigen::Vector3d LatLonToNed(const GeoPoint& origin, const GeoPoint& point);
// Inverse of LatLonToNed.
GeoPoint NedToLatLon(const GeoPoint& origin, const Eigen::Vector3d& p_N_m);

enum class MissionItemType { kTakeoff, kWaypoint, kHold, kPayload, kLand };
enum class PayloadAction { kAttach, kRelease };
enum class YawMode { kTravel, kHold };

struct MissionItem {
  MissionItemType type = MissionItemType::kHold;
  int line = 0;  // 1-based source line, for messages
  // takeoff: height above home; waypoint (geodetic form): height above home.
  double alt_m = 0.0;
  // waypoint
  bool geodetic = false;                        // given as lat/lon/alt: resolved by ResolveMission
  double lat_deg = 0.0;
  double lon_deg = 0.0;
  Eigen::Vector3d p_N_m = Eigen::Vector3d::Zero();  // NED from home (valid when !geodetic)
  std::optional<double> speed_mps;              // default: the mission's
  double hold_s = 0.0;
  std::optional<double> yaw_deg;                // default: by the mission's yaw mode
  // hold
  double duration_s = 0.0;
  // payload
  PayloadAction action = PayloadAction::kAttach;
  double mass_kg = 0.0;
};

struct WindOverride {
  Eigen::Vector3d mean_N_mps = Eigen::Vector3d::Zero();
  double gust_std_mps = 0.0;
};

struct Mission {
  std::string name;
  std::string file;
  double speed_mps = 5.0;
  double acceptance_radius_m = 1.0;
  YawMode yaw_mode = YawMode::kTravel;
  double payload_kg = 0.0;  // attached at the start
  std::optional<WindOverride> wind;
  std::vector<MissionItem> items;
  bool resolved = false;  // every waypoint is in NED (ResolveMission)
};

// Converts geodetic waypoints to NED from `home` (the world's home point). D = −alt_m (height above
// home, flat-world vertical); N and E from LatLonToNed.
Result<Mission> ResolveMission(const Mission& mission, const GeoPoint& home);

const char* MissionItemTypeName(MissionItemType type);

}  // namespace hexsim::control
