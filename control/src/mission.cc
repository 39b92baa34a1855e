#include "hexsim/control/mission.h"

#include <cmath>

#include "hexsim/common/format.h"
#include "hexsim/common/rotation.h"

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

Result<Mission> ResolveMission(const Mission& mission, const GeoPoint& home) {
  if (!std::isfinite(home.lat_deg) || std::abs(home.lat_deg) > 90.0 || !std::isfinite(home.lon_deg)) {
    return Status::BadInput(mission.file + ": home: invalid latitude/longitude");
  }
  Mission out = mission;
  for (MissionItem& it : out.items) {
    if (it.type != MissionItemType::kWaypoint || !it.geodetic) continue;
    const Vector3d ned = LatLonToNed(home, GeoPoint{it.lat_deg, it.lon_deg, home.alt_m + it.alt_m});
    if (ned.head<2>().norm() > kMaxWaypointDistance_m) {
      return Status::BadInput(Format("%s:%d: waypoint lat_deg/lon_deg: %.1f km from home (%s, %s): a mission for another place?",
                                     mission.file.c_str(), it.line, ned.head<2>().norm() / 1000.0,
                                     ShortestDouble(home.lat_deg).c_str(), ShortestDouble(home.lon_deg).c_str()));
    }
    it.p_N_m = Vector3d(ned.x(), ned.y(), -it.alt_m);
    it.geodetic = false;
  }
  out.resolved = true;
  return out;
}

}  // namespace hexsim::control
