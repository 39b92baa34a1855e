#include "hexsim/control/control_io.h"
#include "hexsim/nav/nav_io.h"
#include "hexsim/sim/run_config.h"

#include <fmt/format.h>

#include "hexsim/common/paths.h"
#include "hexsim/common/yaml_reader.h"
#include "hexsim/control/mission.h"
#include "hexsim/nav/estimator.h"
#include "hexsim/vehicle/vehicle_io.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::sim {

namespace {

struct LoadedDoc {
  std::string path;
  YAML::Node node;
};

Result<LoadedDoc> Load(const std::string& kind, const std::string& name) {
  auto path = ResolveWorldFile(kind, name);
  if (!path.ok()) return path.status();
  auto node = YamlReader::LoadFile(*path);
  if (!node.ok()) return node.status();
  return LoadedDoc{*path, *node};
}

// The sets whose key starts with `prefix.`, with the prefix removed.
std::vector<std::string> SetsFor(const std::vector<std::string>& sets, const std::string& prefix) {
  std::vector<std::string> out;
  for (const auto& s : sets) {
    if (s.rfind(prefix + ".", 0) == 0) out.push_back(s.substr(prefix.size() + 1));
  }
  return out;
}

Status ApplySets(YAML::Node node, const std::vector<std::string>& sets, const std::string& file, bool create) {
  for (const auto& s : sets) HEXSIM_RETURN_IF_ERROR(ApplyOverride(node, s, file, create));
  return Status::Ok();
}

// A file's parse error about a value a --set replaced names the --set argument, not the file's line
// (the replaced node has no line of its own: "default_hex.yaml:1: mass_kg" for --set vehicle.mass_kg=abc).
// `prefix` is the sets' root ("vehicle"); the error's field is the key below it, or the whole key
// where the section's reader names it so (`within` false: "control.rate.roll.kp").
Status BlameSets(Status s, const std::vector<std::string>& sets, const std::string& prefix, bool within = true) {
  if (s.ok()) return s;
  const std::string& msg = s.message();
  for (const auto& full : sets) {
    if (full.rfind(prefix + ".", 0) != 0) continue;
    const std::string assignment = within ? full.substr(prefix.size() + 1) : full;
    const std::string key = assignment.substr(0, assignment.find('='));
    const size_t at = msg.find(": " + key + ": ");
    if (at == std::string::npos) continue;
    return Status::BadInput(fmt::format("--set {}: {}", full, msg.substr(at + 2)));
  }
  return s;
}

// A section taken out of a document (so the vehicle parser does not see it), or an empty map.
YAML::Node TakeSection(YAML::Node doc, const std::string& key) {
  YAML::Node section(YAML::NodeType::Map);
  if (doc.IsMap() && doc[key].IsDefined()) {
    section = YAML::Clone(doc[key]);
    doc.remove(key);
  }
  return section;
}

}  // namespace

Result<RunSetup> LoadRunSetup(const RunRequest& req) {
  for (const auto& s : req.sets) {
    const auto dot = s.find('.');
    const auto eq = s.find('=');
    const std::string head = s.substr(0, std::min(dot, eq));
    if (eq == std::string::npos || dot == std::string::npos || dot > eq ||
        (head != "mission" && head != "vehicle" && head != "world" && head != "control" && head != "nav" &&
         head != "sim")) {
      return Status::BadInput(fmt::format(
          "--set {}: expected KEY=VALUE with KEY starting mission., vehicle., world., control., nav. or sim.", s));
    }
  }
  RunSetup setup;

  // World.
  auto world_doc = Load("environments", req.world);
  if (!world_doc.ok()) return world_doc.status();
  HEXSIM_RETURN_IF_ERROR(ApplySets(world_doc->node, SetsFor(req.sets, "world"), world_doc->path, false));
  auto world = ParseWorld(world_doc->node, world_doc->path);
  if (!world.ok()) return BlameSets(world.status(), req.sets, "world");
  setup.world = *world;
  if (req.allow_field_extrapolation) setup.world.allow_field_extrapolation = true;
  setup.world_name = FileStem(world_doc->path);

  // Vehicle, with its control and nav sections.
  auto vehicle_doc = Load("vehicles", req.vehicle);
  if (!vehicle_doc.ok()) return vehicle_doc.status();
  YAML::Node vnode = vehicle_doc->node;
  YAML::Node control_node = TakeSection(vnode, "control");
  YAML::Node nav_node = TakeSection(vnode, "nav");
  HEXSIM_RETURN_IF_ERROR(ApplySets(vnode, SetsFor(req.sets, "vehicle"), vehicle_doc->path, false));
  auto vehicle = vehicle::ParseVehicle(vnode, vehicle_doc->path);
  if (!vehicle.ok()) return BlameSets(vehicle.status(), req.sets, "vehicle");
  setup.vehicle = *vehicle;
  setup.vehicle_name = FileStem(vehicle_doc->path);

  HEXSIM_RETURN_IF_ERROR(ApplySets(control_node, SetsFor(req.sets, "control"), "--set control", true));
  {
    YamlReader r(control_node, vehicle_doc->path, "control");
    HEXSIM_RETURN_IF_ERROR(BlameSets(control::ParseControllerParams(r, &setup.control), req.sets, "control", false));
    HEXSIM_RETURN_IF_ERROR(BlameSets(r.Finish(), req.sets, "control", false));
  }
  HEXSIM_RETURN_IF_ERROR(ApplySets(nav_node, SetsFor(req.sets, "nav"), "--set nav", true));
  {
    YamlReader r(nav_node, vehicle_doc->path, "nav");
    HEXSIM_RETURN_IF_ERROR(BlameSets(nav::ParseNavParams(r, &setup.nav), req.sets, "nav", false));
    HEXSIM_RETURN_IF_ERROR(BlameSets(r.Finish(), req.sets, "nav", false));
  }

  // Mission.
  auto mission_doc = Load("missions", req.mission);
  if (!mission_doc.ok()) return mission_doc.status();
  HEXSIM_RETURN_IF_ERROR(ApplySets(mission_doc->node, SetsFor(req.sets, "mission"), mission_doc->path, false));
  auto mission = control::ParseMission(mission_doc->node, mission_doc->path);
  if (!mission.ok()) return BlameSets(mission.status(), req.sets, "mission");
  auto resolved = control::ResolveMission(
      *mission, control::GeoPoint{setup.world.home_lat_deg, setup.world.home_lon_deg, setup.world.home_alt_m});
  if (!resolved.ok()) return resolved.status();
  setup.mission = *resolved;
  setup.mission_name = FileStem(mission_doc->path);

  // Simulator options.
  YAML::Node sim_node(YAML::NodeType::Map);
  HEXSIM_RETURN_IF_ERROR(ApplySets(sim_node, SetsFor(req.sets, "sim"), "--set sim", true));
  SimOptions& o = setup.options;
  {
    YamlReader r(sim_node, "--set", "sim");
    r.Opt("physics_dt_s", &o.physics_dt_s, InRange(1e-5, 0.01));
    r.Opt("log_rate_hz", &o.log_rate_hz, Positive());
    r.Opt("stream_rate_hz", &o.stream_rate_hz, InRange(0.0, 1e5));
    r.Opt("max_duration_s", &o.max_duration_s, Positive());
    r.Opt("estimator", &o.estimator, {"truth", "eskf", "complementary"});
    r.Opt("write_log", &o.write_log);
    r.Opt("control_on_truth", &o.control_on_truth);
    if (r.Has("motor_slew_up_per_s")) {
      r.Fail("motor_slew_up_per_s", "removed: the spool-up is the vehicle's esc.spool_up_time_s (--set vehicle.esc.spool_up_time_s=S)");
    }
    HEXSIM_RETURN_IF_ERROR(r.Finish());
  }
  if (!req.estimator.empty()) o.estimator = req.estimator;
  o.seed = req.seed;
  o.duration_s = req.duration_s;
  HEXSIM_RETURN_IF_ERROR(ValidateRunSetup(setup));
  return setup;
}

}  // namespace hexsim::sim
