// The selftest's real profile: degrading a simulated trial log to real logging (private to gap/).
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "channels.h"
#include "hexsim/common/rng.h"
#include "hexsim/common/status.h"
#include "hexsim/gap/effects.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::gap::internal {

struct RealLogTruth {
  double latency_s = 0.0, staleness_s = 0.0;
  Vec3 offset_uT = Vec3::Zero();  // added to the selftest compass (sensor frame)
  double scale = 0.0;             // its field-norm error
};

// A direction drawn uniformly on the unit sphere.
Vec3 RandomUnit(RngStream* rng);

// A form injected into a trial log that no library candidate has by its name. `named_right`: the
// verdicts that name it right (the library effect it is a form of); an honest "not confident"
// (unexplained, ambiguous, partial, or its leftover reported) is right for every form, and the only
// right answer where `named_right` is empty.
struct LogForm {
  const char* name;
  std::vector<Effect> named_right;
};
// Effect families outside the library, one drawn per out-of-library trial (named_right empty).
const std::vector<LogForm>& OutOfLibraryFamilies();
// Adds `family` to compass `compass` (0-based) of a trial log, in the sensor frame.
Status InjectOutOfLibrary(logs::FlightLog* log, size_t compass, const std::string& family, RngStream* rng);

// Forms beyond the library's names, each with the effect it is a form of (class beyond_library;
// selftest_forms.cc): a lagged power-law current field, a field following the battery's voltage sag,
// a field driven by the throttle's square (not the current), a current sensor that drops out, one
// that clips, and a temperature-driven offset that lags the logged temperature.
const std::vector<LogForm>& BeyondLibraryForms();
// The truth of a form that the outcome reports beside the verdict (NaN where the form has none).
struct FormTruth {
  double lag_s = std::nan("");  // the lagged field's time constant
};
// Adds `form` to compass `compass` (0-based) of a trial log at the simulator's rate (before
// DegradeToRealLog), in the sensor frame; the current-sensor forms also corrupt `current_A`.
Result<FormTruth> InjectBeyondLibrary(logs::FlightLog* log, size_t compass, const std::string& form, RngStream* rng);
// A form by name (null: none).
const LogForm* FindForm(const std::string& name);
// The log as a real autopilot would have logged it (see selftest_real.cc).
Result<logs::FlightLog> DegradeToRealLog(const logs::FlightLog& in, const vehicle::VehicleParams& configured,
                                         RngStream* rng, RealLogTruth* truth);

}  // namespace hexsim::gap::internal
