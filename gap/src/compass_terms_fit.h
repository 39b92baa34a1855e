// The absolute terms of a compass channel from the in-flight model (compass_terms.h), its JSON and
// its stdout line (private to gap/).
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "hexsim/common/status.h"
#include "hexsim/gap/compass_terms.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/realdata/windows.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::gap::internal {

// Vehicle compass c (column prefix `name`) fitted by realdata::FitCompassInFlight on `windows`, with
// the vehicle file's modelled field per ampere beside it. Errors: the model's own (too few samples
// or blocks, with the minimum named; no attitude or place).
Result<CompassTerms> FitCompassTerms(const logs::FlightLog& log, const vehicle::VehicleParams& v, size_t c,
                                     const std::string& name, const realdata::FlightWindows& windows, uint64_t seed);

nlohmann::json CompassTermsJson(const CompassTerms& terms);
// "absolute (as hexsim calibrate): current field 6.5 mG/A [5.3, 7.7] ...; vehicle file 0.3 mG/A: gap ...".
std::string CompassTermsText(const CompassTerms& terms);

}  // namespace hexsim::gap::internal
