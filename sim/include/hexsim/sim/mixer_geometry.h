// The mixer's view of a vehicle's rotors.
#pragma once

#include <vector>

#include "hexsim/control/mixer.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::sim {

// The mixer's rotor geometry (position, thrust axis, spin, torque-to-thrust ratio) of the vehicle's
// rotors, in the vehicle file's order: what control::Mixer and control::AllocationMatrix take.
std::vector<control::RotorGeometry> MixerGeometry(const vehicle::VehicleParams& vehicle);

}  // namespace hexsim::sim
