#include "hexsim/control/control_io.h"
#include "hexsim/control/mission.h"

#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "hexsim/common/yaml_reader.h"

namespace hexsim::control {
namespace {

using Eigen::Vector3d;

Result<Mission> ParseText(const std::string& text, const std::string& file = "m.yaml") {
  Result<YAML::Node> node = YamlReader::LoadString(text, file);
  if (!node.ok()) return node.status();
  return ParseMission(*node, file);
}

std::string ErrorOf(const std::string& text) {
  const Result<Mission> m = ParseText(text);
  EXPECT_FALSE(m.ok());
  return m.ok() ? std::string() : m.status().message();
}

TEST(MissionTest, GivenFullMission_WhenParsed_ThenEveryItemAndDefaultIsRead) {
  const Result<Mission> m = ParseText(
      "speed_mps: 4\n"
      "acceptance_radius_m: 2\n"
      "yaw_mode: hold\n"
      "payload_kg: 1.5\n"
      "wind: {mean_N_mps: [3, -1, 0], gust_std_mps: 0.5}\n"
      "items:\n"
      "  - {type: takeoff, alt_m: 10}\n"
      "  - {type: waypoint, p_N_m: [20, 5, -10], speed_mps: 6, hold_s: 2, yaw_deg: 90}\n"
      "  - {type: hold, duration_s: 5}\n"
      "  - {type: payload, action: release, mass_kg: 1.5}\n"
      "  - {type: waypoint, lat_deg: 43.881, lon_deg: 125.35, alt_m: 12}\n"
      "  - {type: land}\n",
      "dir/my_mission.yaml");
  ASSERT_TRUE(m.ok()) << m.status().message();
  EXPECT_EQ(m->name, "my_mission");
  EXPECT_DOUBLE_EQ(m->speed_mps, 4.0);
  EXPECT_DOUBLE_EQ(m->acceptance_radius_m, 2.0);
  EXPECT_EQ(m->yaw_mode, YawMode::kHold);
  EXPECT_DOUBLE_EQ(m->payload_kg, 1.5);
  ASSERT_TRUE(m->wind.has_value());
  EXPECT_EQ(m->wind->mean_N_mps, Vector3d(3, -1, 0));
  ASSERT_EQ(m->items.size(), 6u);
  EXPECT_EQ(m->items[0].type, MissionItemType::kTakeoff);
  EXPECT_DOUBLE_EQ(m->items[0].alt_m, 10.0);
  const MissionItem& wp = m->items[1];
  EXPECT_EQ(wp.p_N_m, Vector3d(20, 5, -10));
  EXPECT_DOUBLE_EQ(*wp.speed_mps, 6.0);
  EXPECT_DOUBLE_EQ(wp.hold_s, 2.0);
  EXPECT_DOUBLE_EQ(*wp.yaw_deg, 90.0);
  EXPECT_EQ(wp.line, 8);
  EXPECT_EQ(m->items[3].action, PayloadAction::kRelease);
  EXPECT_TRUE(m->items[4].geodetic);
  EXPECT_FALSE(m->items[4].speed_mps.has_value());
  EXPECT_FALSE(m->resolved);
  EXPECT_EQ(m->items[5].type, MissionItemType::kLand);
}

TEST(MissionTest, GivenNegativeSpeed_WhenParsed_ThenErrorNamesFileLineAndField) {
  EXPECT_EQ(ErrorOf("items:\n"
                    "  - {type: takeoff, alt_m: 10}\n"
                    "  - {type: waypoint, p_N_m: [1, 0, -10]}\n"
                    "  - {type: hold, duration_s: 1}\n"
                    "  - {type: waypoint, p_N_m: [2, 0, -10], speed_mps: -2}\n"),
            "m.yaml:5: items[3].speed_mps: must be > 0 (got -2)");
}

TEST(MissionTest, GivenMalformedItems_WhenParsed_ThenEachErrorSaysWhatIsWrongAndWhere) {
  EXPECT_EQ(ErrorOf("items:\n  - {type: fly, alt_m: 3}\n"),
            "m.yaml:2: items[0].type: 'fly' is not one of: takeoff, waypoint, hold, payload, land");
  EXPECT_EQ(ErrorOf("items:\n  - {alt_m: 3}\n"),
            "m.yaml:2: items[0].type: required field is missing (takeoff, waypoint, hold, payload or land)");
  EXPECT_EQ(ErrorOf("items:\n  - {type: takeoff, alt_m: 3, speed_mps: 2}\n"),
            "m.yaml:2: items[0].speed_mps: unknown key");
  EXPECT_EQ(ErrorOf("items:\n  - {type: waypoint, p_N_m: [1, 2]}\n"), "m.yaml:2: items[0].p_N_m: expected [x, y, z]");
  EXPECT_EQ(ErrorOf("items:\n  - {type: waypoint, p_N_m: [1, 2, 3], lat_deg: 4}\n"),
            "m.yaml:2: items[0].p_N_m: give either p_N_m or lat_deg/lon_deg/alt_m, not both");
  EXPECT_EQ(ErrorOf("items:\n  - {type: waypoint, lat_deg: 43.0, lon_deg: 120.0}\n"),
            "m.yaml:2: items[0].alt_m: required field is missing");
  EXPECT_EQ(ErrorOf("items: []\n"), "m.yaml:1: items: must not be empty");
  EXPECT_EQ(ErrorOf("speed: 3\nitems:\n  - {type: land}\n"), "m.yaml:1: speed: unknown key");
  EXPECT_EQ(ErrorOf("items:\n  - {type: takeoff, alt_m: 5}\n  - {type: payload, action: release, mass_kg: 1}\n"),
            "m.yaml:3: items[1].mass_kg: releases 1 kg but only 0 kg is carried");
}

TEST(LatLonToNedTest, GivenOneThousandthDegreeAt45N_ThenDistancesMatchTheWgs84DegreeLengths) {
  // Published WGS-84 lengths of one degree at 45°: latitude 111 132.954 m, longitude 78 846.835 m.
  const GeoPoint origin{45.0, 10.0, 100.0};
  const Vector3d north = LatLonToNed(origin, GeoPoint{45.001, 10.0, 100.0});
  const Vector3d east = LatLonToNed(origin, GeoPoint{45.0, 10.001, 100.0});
  // The degree lengths are for arcs centred on 45°; a 0.001° step from 45° differs by < 1 mm.
  EXPECT_NEAR(north.x(), 111.132954, 0.005);
  EXPECT_NEAR(north.y(), 0.0, 1e-9);
  EXPECT_NEAR(east.y(), 78.846835, 0.005);
  EXPECT_NEAR(east.x(), 0.0, 0.005);  // meridian convergence over 79 m: < 1 mm
  // Curvature: a point at the origin's height lies d²/(2R) below the tangent plane.
  EXPECT_NEAR(north.z(), 111.13 * 111.13 / (2 * 6.37e6), 1e-4);
  const Vector3d up = LatLonToNed(origin, GeoPoint{45.0, 10.0, 150.0});
  EXPECT_NEAR(up.z(), -50.0, 1e-9);
}

TEST(LatLonToNedTest, GivenKilometreOffsets_WhenConvertedAndBack_ThenRoundTripIsExactToMillimetres) {
  const GeoPoint home{43.88, 125.35, 200.0};
  for (const Vector3d& p : {Vector3d(1500, -700, -30), Vector3d(-4000, 2500, 5), Vector3d(0, 0, 0)}) {
    const GeoPoint g = NedToLatLon(home, p);
    EXPECT_LT((LatLonToNed(home, g) - p).norm(), 1e-6);
  }
}

TEST(MissionTest, GivenGeodeticWaypoints_WhenResolved_ThenTheyBecomeNedFromHomeAtHeightAboveHome) {
  const GeoPoint home{43.88, 125.35, 200.0};
  const GeoPoint target = NedToLatLon(home, Vector3d(120.0, -80.0, 0.0));
  const std::string text = "items:\n  - {type: takeoff, alt_m: 10}\n  - {type: waypoint, lat_deg: " +
                           std::to_string(target.lat_deg) + ", lon_deg: " + std::to_string(target.lon_deg) +
                           ", alt_m: 15}\n";
  const Result<Mission> m = ParseText(text);
  ASSERT_TRUE(m.ok()) << m.status().message();
  const Result<Mission> r = ResolveMission(*m, home);
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_TRUE(r->resolved);
  const Vector3d p = r->items[1].p_N_m;
  // std::to_string keeps 6 decimals: 1e-6° ≈ 0.11 m.
  EXPECT_NEAR(p.x(), 120.0, 0.12);
  EXPECT_NEAR(p.y(), -80.0, 0.12);
  EXPECT_DOUBLE_EQ(p.z(), -15.0);
  // The same mission against a home on another continent is bad input.
  const Result<Mission> far = ResolveMission(*m, GeoPoint{52.0, 4.0, 0.0});
  ASSERT_FALSE(far.ok());
  EXPECT_EQ(far.status().code(), StatusCode::kBadInput);
}

}  // namespace
}  // namespace hexsim::control
