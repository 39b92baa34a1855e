// Which compass of the vehicle file each compass of the log is compared with (private to gap/).
#pragma once

#include <string>
#include <vector>

#include "hexsim/gap/diagnose.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::gap::internal {

// By the external flag where both sides state it: the log meta's compasses[].external (DataFlash
// COMPASS_EXTERNn, PX4 CAL_MAGn_ROT) for every compass column with data, and a vehicle file that
// marks at least one compass `external` (an unmarked file says nothing: its flags all default to
// false). Each log compass takes the vehicle's compass of its own kind, its own index when that one
// is of its kind, else the first one of that kind not yet taken, else (more log compasses of a kind
// than the file has) the first one of its kind, shared and said so in `why`. Otherwise (a flag
// missing, or no compass of that kind in the file) by index, with the reason in `why`.
CompassMapping MapCompasses(const logs::FlightLog& log, const vehicle::VehicleParams& v);

// The vehicle with its compasses reordered so that compass c is the one log compass c is compared
// with (the rest keep their order in the free places): everything downstream indexes both by c.
vehicle::VehicleParams WithCompassesInLogOrder(const vehicle::VehicleParams& v, const CompassMapping& m);

}  // namespace hexsim::gap::internal
