// Shared by turntable, calibrate, heading-error, compare and --calibration METHOD.
#pragma once

#include <string>
#include <vector>

#include "hexsim/common/status.h"
#include "hexsim/sim/turntable.h"
#include "hexsim/sim/world.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::app {

struct VehicleAndWorld {
  vehicle::VehicleParams vehicle;
  sim::WorldParams world;
  std::string vehicle_name, world_name;
};

// Loads a vehicle and a world by name or path (no overrides).
Result<VehicleAndWorld> LoadVehicleAndWorld(const std::string& vehicle, const std::string& world);

// "0,200,300" -> {0, 200, 300}; "xy,yz" -> {"xy", "yz"}.
Result<std::vector<double>> ParseNumberList(const std::string& text, const std::string& flag);
std::vector<std::string> SplitList(const std::string& text);

}  // namespace hexsim::app
