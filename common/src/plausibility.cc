// The one plausibility table (see plausibility.h). Magnitudes are the figures the consumers report:
// vector effects by their Euclidean norm, signed scalars by their value.
#include "hexsim/common/plausibility.h"

#include <cmath>
#include <cstdio>

namespace hexsim::plausibility {
namespace {

PhysicalRange Effect(const char* name, const char* unit, double lo, double hi, const char* reason) {
  return {name, unit, lo, hi, lo, hi, reason};
}

}  // namespace

const std::vector<PhysicalRange>& PlausibilityTable() {
  static const std::vector<PhysicalRange> kTable = {
      // Compass effects (magnitudes in µT-based units; 1 µT = 10 mG).
      Effect("current_hard_iron", "uT/A", 0.0, 5.0,
             "|dB/dI| <= 50 mG/A: a 1 A wire 4 mm from the sensor gives 50 mG; real internal compasses show 3-7 mG/A"),
      Effect("per_motor_current_hard_iron", "uT", 0.0, 60.0,
             "|field per motor at full output| <= 600 mG: ~60 A through an ESC lead no closer than 2 cm"),
      Effect("throttle_hard_iron", "uT/throttle", 0.0, 60.0,
             "|field at full throttle| <= 600 mG: the 50 mG/A current bound over a ~12 A idle-to-full current swing"),
      Effect("current_soft_iron", "1/A", 0.0, 0.01,
             "soft-iron change <= 1 % per ampere: DC currents barely move the permeability of nearby steel"),
      Effect("misalignment", "deg", 0.0, 10.0,
             "mounting tolerance of a compass board is a few degrees; beyond 10 deg it is a wrong orientation setting"),
      Effect("scale_error", "1", -0.2, 0.2,
             "sensor gain tolerance after calibration is a few percent; 20 % means the wrong range or model"),
      Effect("temperature_drift", "uT/C", 0.0, 0.5,
             "offset tempco of AMR/MEMS compasses is ~0.01-0.1 uT/C; 0.5 uT/C would move 10 uT over a flight"),
      Effect("current_lag", "s", 0.0, 2.0,
             "current-field lag from ESC/sense filtering and eddy currents: well under a second"),
      {"latency", "s", 0.0, 0.5, 0.0, 0.1,
       "sensor-to-log delays are tens of milliseconds (driver filtering, 10-100 Hz reads); a half-second delay "
       "breaks the autopilot's fusion"},
      Effect("current_staleness", "s", 0.0, 1.0,
             "battery monitors update at 1-10 Hz with filtering: up to a few samples old"),
      // Nuisance terms of every compass fit (normal range: nothing to act on).
      {"hard_iron_offset", "uT", 0.0, 85.0, 0.0, 5.0,
       "residual offset after a calibration is a few uT (<= 50 mG); ArduPilot rejects offsets over 850 mG"},
      {"field_scale", "1", 0.7, 1.3, 0.95, 1.05,
       "fitted field norm / WMM norm: a calibrated compass reads the Earth field within 5 %; 30 % is a wrong "
       "scale or a strong anomaly"},
      {"local_anomaly", "uT", 0.0, 30.0, 0.0, 3.0,
       "difference of the fitted NED field from WMM: crustal anomalies are ~0.2-2 uT, steel structures nearby more"},
      // Dynamics channel.
      Effect("rotor_drag", "N/((rad/s)(m/s))", 0.0, 1e-3,
             "induced drag of a small rotor: ~1e-5..1e-4 N per (rad/s)(m/s); never negative"),
      Effect("ground_effect", "m", 0.0, 1.0, "effective rotor radius of a multirotor's ground effect: below a metre"),
      Effect("battery_sag", "Ohm", 0.0, 1.0, "pack plus wiring resistance is tens of milliohms; never negative"),
      Effect("motor_time_constant", "s", 0.0, 0.5, "small-motor speed time constants are 20-150 ms"),
      Effect("thrust_scale", "1", 0.5, 2.0, "thrust coefficient or mass within a factor of two of the configured one"),
      Effect("wind", "m/s", 0.0, 25.0, "a multirotor does not fly in mean winds above ~25 m/s"),
  };
  return kTable;
}

const PhysicalRange* FindRange(std::string_view name) {
  for (const auto& r : PlausibilityTable()) {
    if (r.name == name) return &r;
  }
  return nullptr;
}

bool IsPlausible(std::string_view name, double value) {
  const PhysicalRange* r = FindRange(name);
  return r == nullptr || (std::isfinite(value) && value >= r->lo && value <= r->hi);
}

bool IsNormal(std::string_view name, double value) {
  const PhysicalRange* r = FindRange(name);
  return r == nullptr || (std::isfinite(value) && value >= r->normal_lo && value <= r->normal_hi);
}

std::string RangeText(std::string_view name) {
  const PhysicalRange* r = FindRange(name);
  if (r == nullptr) return "no stated range";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g..%g ", r->lo, r->hi);
  return buf + r->unit;
}

}  // namespace hexsim::plausibility
