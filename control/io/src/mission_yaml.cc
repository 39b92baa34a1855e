// Mission from the mission YAML (the format is in hexsim/control/mission.h).
#include <fmt/format.h>

#include "hexsim/control/control_io.h"

namespace hexsim::control {

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

}  // namespace hexsim::control
