// The selftest's real profile: degrading a simulated trial log to real logging (private to gap/).
#pragma once

#include <string>
#include <vector>

#include "channels.h"
#include "hexsim/common/rng.h"
#include "hexsim/common/status.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::gap::internal {

struct RealLogTruth {
  double latency_s = 0.0, staleness_s = 0.0;
  Vec3 offset_uT = Vec3::Zero();  // added to the selftest compass (sensor frame)
  double scale = 0.0;             // its field-norm error
};

// Effect families outside the library, one drawn per out-of-library trial.
const std::vector<std::string>& OutOfLibraryFamilies();
// Adds `family` to compass `compass` (0-based) of a trial log, in the sensor frame.
Status InjectOutOfLibrary(logs::FlightLog* log, size_t compass, const std::string& family, RngStream* rng);
// The log as a real autopilot would have logged it (see selftest_real.cc).
Result<logs::FlightLog> DegradeToRealLog(const logs::FlightLog& in, const vehicle::VehicleParams& configured,
                                         RngStream* rng, RealLogTruth* truth);

}  // namespace hexsim::gap::internal
