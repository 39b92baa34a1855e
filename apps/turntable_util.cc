#include "turntable_util.h"

#include <cmath>
#include <cstdlib>
#include <sstream>

#include <fmt/format.h>

#include "hexsim/common/paths.h"
#include "hexsim/common/yaml_reader.h"
#include "hexsim/vehicle/vehicle_io.h"

namespace hexsim::app {

Result<VehicleAndWorld> LoadVehicleAndWorld(const std::string& vehicle, const std::string& world) {
  VehicleAndWorld out;
  auto vpath = ResolveWorldFile("vehicles", vehicle);
  if (!vpath.ok()) return vpath.status();
  auto vnode = YamlReader::LoadFile(*vpath);
  if (!vnode.ok()) return vnode.status();
  YAML::Node v = *vnode;
  v.remove("control");
  v.remove("nav");
  auto vp = vehicle::ParseVehicle(v, *vpath);
  if (!vp.ok()) return vp.status();
  out.vehicle = *vp;
  out.vehicle_name = FileStem(*vpath);
  auto wpath = ResolveWorldFile("environments", world);
  if (!wpath.ok()) return wpath.status();
  auto wnode = YamlReader::LoadFile(*wpath);
  if (!wnode.ok()) return wnode.status();
  auto wp = sim::ParseWorld(*wnode, *wpath);
  if (!wp.ok()) return wp.status();
  out.world = *wp;
  out.world_name = FileStem(*wpath);
  return out;
}

std::vector<std::string> SplitList(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

Result<std::vector<double>> ParseNumberList(const std::string& text, const std::string& flag) {
  std::vector<double> out;
  for (const auto& item : SplitList(text)) {
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    if (end == item.c_str() || *end != '\0' || !std::isfinite(v)) {
      return Status::BadInput(fmt::format("{}: '{}' is not a number", flag, item));
    }
    out.push_back(v);
  }
  if (out.empty()) return Status::BadInput(flag + ": expected a comma-separated list of numbers");
  return out;
}

}  // namespace hexsim::app
