// The vehicle YAML (worlds/vehicles/*.yaml) -> VehicleParams. hexsim::vehicle_io, on yaml-cpp
// (hexsim::common_io's YamlReader); the core hexsim::vehicle needs only the standard library and Eigen.
#pragma once

#include <string>

#include <yaml-cpp/yaml.h>

#include "hexsim/common/status.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::vehicle {

// Reads a vehicle document (already loaded, --set overrides applied). Every field is validated and
// unknown keys are rejected; errors read "FILE:LINE: FIELD: what is wrong".
Result<VehicleParams> ParseVehicle(const YAML::Node& root, const std::string& file);
// Loads and parses a vehicle file.
Result<VehicleParams> LoadVehicleFile(const std::string& path);

}  // namespace hexsim::vehicle
