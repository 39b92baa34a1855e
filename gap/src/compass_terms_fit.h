// The absolute terms of a compass channel from the in-flight model (compass_terms.h), its JSON and
// its stdout line (private to gap/).
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hexsim/common/status.h"
#include "hexsim/gap/compass_terms.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/realdata/compass_flight.h"
#include "hexsim/realdata/windows.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::gap::internal {

// Vehicle compass c (column prefix `name`) fitted by realdata::FitCompassInFlight on `windows`, with
// the vehicle file's modelled field per ampere beside it. Errors: the model's own (too few samples
// or blocks, with the minimum named; no attitude or place). `staleness`: the model's current
// staleness on this log and windows, computed once for every compass (null: computed here;
// realdata::CompassFlightOptions::staleness).
Result<CompassTerms> FitCompassTerms(const logs::FlightLog& log, const vehicle::VehicleParams& v, size_t c,
                                     const std::string& name, const realdata::FlightWindows& windows, uint64_t seed,
                                     const realdata::LagEstimate* staleness = nullptr);

// Why a throttle-driven field's current equivalent (|d|/(dI/du), µT/A) must not be printed, empty
// when it may: a throttle field is a current field only where the current carries it, so the
// equivalent is kept where the log's current is usable (the model fitted the current form) and it
// lies inside the model's own current term's 95 % interval, the same log fitted directly on the
// current. ArduCopter log_0036's external compass: 3.7 mG/A through the slope against 0.8 [0.5,
// 1.0] mG/A on the current: a field that follows the throttle, not the current.
std::string CurrentEquivalentRefusal(const Result<CompassTerms>& terms, double equivalent_uT_per_A);

// The current's shift for gap's prediction (the vehicle file's wiring field) and its plug-in range
// (PropagatePlugIns): the in-flight model's own choice on this compass where it resolves its
// current term (its interval clear of zero: a term the data do not resolve chooses its shift by the
// noise), one shift per compass for both; else `scan` (the throttle scan's estimate) at its point
// `scan_shift_s`. The model's choice ranges over its delete-one-block choices widened by one step of
// its shift grid either side: the choice resolves the shift only to its grid, and the smallest and
// largest of G delete-one choices span about one standard error, not a 95 % interval (delete-one
// fits that all choose one member would give a zero-width range). `grid`: the shifts profiled
// (realdata::CurrentShiftGrid).
struct CurrentShift {
  double value_s = 0.0;
  realdata::LagEstimate plug_in;
};
CurrentShift PredictionCurrentShift(const Result<CompassTerms>& terms, const realdata::LagEstimate& scan,
                                    double scan_shift_s, const std::vector<double>& grid);

nlohmann::json CompassTermsJson(const CompassTerms& terms);
// "absolute (as hexsim calibrate): current field 6.5 mG/A [5.3, 7.7] ...; vehicle file 0.3 mG/A: gap ...".
std::string CompassTermsText(const CompassTerms& terms);

}  // namespace hexsim::gap::internal
