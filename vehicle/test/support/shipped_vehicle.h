// The shipped vehicle files (worlds/vehicles/NAME.yaml), loaded for the vehicle tests.
#pragma once

#include <string>

#include "hexsim/common/status.h"
#include "hexsim/vehicle/vehicle_io.h"

namespace hexsim::vehicle::vehicletest {

inline VehicleParams LoadShipped(const std::string& name) {
  Result<VehicleParams> v = LoadVehicleFile(std::string(HEXSIM_SOURCE_DIR) + "/worlds/vehicles/" + name + ".yaml");
  HEXSIM_CHECK(v.ok());
  return *v;
}

}  // namespace hexsim::vehicle::vehicletest
