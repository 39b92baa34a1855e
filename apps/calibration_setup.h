// --calibration NAME|FILE: a method name (learnt on the simulated turntable first, from sensor data
// only) or a calib.yaml written by `hexsim calibrate`.
#pragma once

#include <string>

#include "hexsim/common/status.h"
#include "hexsim/sim/simulation.h"

namespace hexsim::app {

Status AttachCalibration(const std::string& calibration, sim::RunSetup* setup);

}  // namespace hexsim::app
