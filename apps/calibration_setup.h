// --calibration NAME|FILE: a method name (learnt on the simulated turntable first, from sensor data
// only) or a calib.yaml written by `hexsim calibrate`.
#pragma once

#include <string>

#include "hexsim/common/status.h"
#include "hexsim/magnetics/compensator.h"
#include "hexsim/sim/simulation.h"

namespace hexsim::app {

Status AttachCalibration(const std::string& calibration, sim::RunSetup* setup);

// Runs the simulated turntable (all three planes, control 0/200/300) for the setup's vehicle and
// world and learns `method` from the compass-1 samples, as a user would on the ground.
Result<std::shared_ptr<const magnetics::Compensator>> LearnOnTurntable(const std::string& method,
                                                                       const sim::RunSetup& setup);

}  // namespace hexsim::app
