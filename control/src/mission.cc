#include "hexsim/control/mission.h"

#include <cmath>

#include <fmt/format.h>

#include "hexsim/common/rotation.h"
#include "hexsim/common/yaml_reader.h"

namespace hexsim::control {

using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {

constexpr double kWgs84A_m = 6378137.0;
constexpr double kWgs84F = 1.0 / 298.257223563;
constexpr double kWgs84E2 = kWgs84F * (2.0 - kWgs84F);
// A geodetic waypoint farther than this from home is taken as a mission meant for another world.
constexpr double kMaxWaypointDistance_m = 50e3;

Vector3d GeodeticToEcef(const GeoPoint& g) {
  const double lat = g.lat_deg * kDegToRad, lon = g.lon_deg * kDegToRad;
  const double s = std::sin(lat), c = std::cos(lat);
  const double n = kWgs84A_m / std::sqrt(1.0 - kWgs84E2 * s * s);  // prime-vertical radius
  return {(n + g.alt_m) * c * std::cos(lon), (n + g.alt_m) * c * std::sin(lon),
          (n * (1.0 - kWgs84E2) + g.alt_m) * s};
}

GeoPoint EcefToGeodetic(const Vector3d& x) {
  const double lon = std::atan2(x.y(), x.x());
  const double p = std::hypot(x.x(), x.y());
  double lat = std::atan2(x.z(), p * (1.0 - kWgs84E2));
  double h = 0.0;
  for (int i = 0; i < 10; ++i) {  // fixed-point iteration, converges to < 1e-12 rad in a few steps
    const double s = std::sin(lat);
    const double n = kWgs84A_m / std::sqrt(1.0 - kWgs84E2 * s * s);
    h = p / std::cos(lat) - n;
    lat = std::atan2(x.z(), p * (1.0 - kWgs84E2 * n / (n + h)));
  }
  return {lat * kRadToDeg, lon * kRadToDeg, h};
}

// Rows: the N, E, D unit vectors at `origin`, in ECEF.
Matrix3d EcefToNed(const GeoPoint& origin) {
  const double lat = origin.lat_deg * kDegToRad, lon = origin.lon_deg * kDegToRad;
  const double sl = std::sin(lat), cl = std::cos(lat), so = std::sin(lon), co = std::cos(lon);
  Matrix3d R;
  R << -sl * co, -sl * so, cl,
       -so, co, 0.0,
       -cl * co, -cl * so, -sl;
  return R;
}

}  // namespace

Vector3d LatLonToNed(const GeoPoint& origin, const GeoPoint& point) {
  return EcefToNed(origin) * (GeodeticToEcef(point) - GeodeticToEcef(origin));
}

GeoPoint NedToLatLon(const GeoPoint& origin, const Vector3d& p_N_m) {
  return EcefToGeodetic(GeodeticToEcef(origin) + EcefToNed(origin).transpose() * p_N_m);
}

const char* MissionItemTypeName(MissionItemType type) {
  switch (type) {
    case MissionItemType::kTakeoff: return "takeoff";
    case MissionItemType::kWaypoint: return "waypoint";
    case MissionItemType::kHold: return "hold";
    case MissionItemType::kPayload: return "payload";
    case MissionItemType::kLand: return "land";
  }
  return "?";
}

namespace {

void ParseItem(YamlReader& r, MissionItem* item) {
  item->line = r.node().Mark().line + 1;
  std::string type;
  if (!r.Has("type")) r.Fail("type", "required field is missing (takeoff, waypoint, hold, payload or land)");
  r.Opt("type", &type, {"takeoff", "waypoint", "hold", "payload", "land"});
  if (!r.ok()) return;
  if (type == "takeoff") {
    item->type = MissionItemType::kTakeoff;
    r.Req("alt_m", &item->alt_m, Positive());
  } else if (type == "waypoint") {
    item->type = MissionItemType::kWaypoint;
    const bool ned = r.Has("p_N_m");
    const bool geo = r.Has("lat_deg") || r.Has("lon_deg");
    if (ned && geo) {
      r.Fail("p_N_m", "give either p_N_m or lat_deg/lon_deg/alt_m, not both");
      return;
    }
    if (ned) {
      r.Req("p_N_m", &item->p_N_m);
    } else {
      item->geodetic = true;
      r.Req("lat_deg", &item->lat_deg, InRange(-90.0, 90.0));
      r.Req("lon_deg", &item->lon_deg, InRange(-180.0, 180.0));
      r.Req("alt_m", &item->alt_m);
    }
    double speed = 0.0;
    if (r.Has("speed_mps")) {
      r.Opt("speed_mps", &speed, Positive());
      item->speed_mps = speed;
    }
    r.Opt("hold_s", &item->hold_s, NonNegative());
    if (r.Has("yaw_deg")) {
      double yaw = 0.0;
      r.Opt("yaw_deg", &yaw, InRange(-360.0, 360.0));
      item->yaw_deg = yaw;
    }
  } else if (type == "hold") {
    item->type = MissionItemType::kHold;
    r.Req("duration_s", &item->duration_s, Positive());
  } else if (type == "payload") {
    item->type = MissionItemType::kPayload;
    std::string action;
    if (!r.Has("action")) r.Fail("action", "required field is missing (attach or release)");
    r.Opt("action", &action, {"attach", "release"});
    item->action = action == "release" ? PayloadAction::kRelease : PayloadAction::kAttach;
    r.Req("mass_kg", &item->mass_kg, Positive());
  } else {
    item->type = MissionItemType::kLand;
  }
}

}  // namespace

Result<Mission> ParseMission(const YAML::Node& node, const std::string& file) {
  Mission m;
  m.file = file;
  YamlReader r(node, file);
  r.Opt("name", &m.name);
  r.Opt("speed_mps", &m.speed_mps, Positive());
  r.Opt("acceptance_radius_m", &m.acceptance_radius_m, Positive());
  std::string yaw_mode = "travel";
  r.Opt("yaw_mode", &yaw_mode, {"travel", "hold"});
  m.yaw_mode = yaw_mode == "hold" ? YawMode::kHold : YawMode::kTravel;
  r.Opt("payload_kg", &m.payload_kg, NonNegative());
  r.Child("wind", [&](YamlReader& w) {
    WindOverride wind;
    w.Opt("mean_N_mps", &wind.mean_N_mps);
    w.Opt("gust_std_mps", &wind.gust_std_mps, NonNegative());
    m.wind = wind;
  });
  r.ForEach(
      "items",
      [&](YamlReader& item, size_t) {
        MissionItem it;
        ParseItem(item, &it);
        m.items.push_back(it);
      },
      /*required=*/true);
  HEXSIM_RETURN_IF_ERROR(r.Finish());

  // Payload bookkeeping: a release needs an attached payload of that mass.
  double carried_kg = m.payload_kg;
  for (size_t i = 0; i < m.items.size(); ++i) {
    const MissionItem& it = m.items[i];
    if (it.type != MissionItemType::kPayload) continue;
    if (it.action == PayloadAction::kAttach) {
      carried_kg += it.mass_kg;
    } else if (it.mass_kg > carried_kg + 1e-9) {
      return Status::BadInput(fmt::format("{}:{}: items[{}].mass_kg: releases {} kg but only {} kg is carried",
                                          file, it.line, i, it.mass_kg, carried_kg));
    } else {
      carried_kg -= it.mass_kg;
    }
  }
  if (m.name.empty()) {
    const size_t slash = file.find_last_of('/');
    std::string stem = slash == std::string::npos ? file : file.substr(slash + 1);
    const size_t dot = stem.find_last_of('.');
    m.name = dot == std::string::npos ? stem : stem.substr(0, dot);
  }
  m.resolved = true;
  for (const MissionItem& it : m.items) {
    if (it.type == MissionItemType::kWaypoint && it.geodetic) m.resolved = false;
  }
  return m;
}

Result<Mission> ResolveMission(const Mission& mission, const GeoPoint& home) {
  if (!std::isfinite(home.lat_deg) || std::abs(home.lat_deg) > 90.0 || !std::isfinite(home.lon_deg)) {
    return Status::BadInput(fmt::format("{}: home: invalid latitude/longitude", mission.file));
  }
  Mission out = mission;
  for (MissionItem& it : out.items) {
    if (it.type != MissionItemType::kWaypoint || !it.geodetic) continue;
    const Vector3d ned = LatLonToNed(home, GeoPoint{it.lat_deg, it.lon_deg, home.alt_m + it.alt_m});
    if (ned.head<2>().norm() > kMaxWaypointDistance_m) {
      return Status::BadInput(fmt::format(
          "{}:{}: waypoint lat_deg/lon_deg: {:.1f} km from home ({}, {}): a mission for another place?",
          mission.file, it.line, ned.head<2>().norm() / 1000.0, home.lat_deg, home.lon_deg));
    }
    it.p_N_m = Vector3d(ned.x(), ned.y(), -it.alt_m);
    it.geodetic = false;
  }
  out.resolved = true;
  return out;
}

}  // namespace hexsim::control
