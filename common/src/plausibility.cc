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
      // The attitude reference's heading error per ampere (gap's reference_yaw, signed): an estimator
      // that fuses a compass the current disturbs turns its heading with that compass's heading error,
      // at most |k|/B_h per ampere (k: the compass's current field, B_h: the horizontal Earth field).
      // At 1 deg/A a hover at the 10-30 A of a small multirotor carries the heading 10-30 deg off: the
      // position loop then circles (toilet-bowls) and the estimator's innovation gate drops the compass,
      // so a flight that held its position lies well inside.
      Effect("reference_yaw", "deg/A", -1.0, 1.0,
             "a reference heading 10-30 deg off at a 10-30 A hover makes a multirotor circle and its estimator "
             "reject the compass; real estimators fusing a 3-7 mG/A compass turn a few tenths of a degree per ampere"),
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
      // Compass calibration (hexsim calibrate: magnetics/field_calibration and ellipsoid_fit). Magnitudes
      // in µT of the raw reading's units after unit detection; shapes unitless (soft iron K, det K = 1).
      Effect("earth_field_norm", "uT", 22.0, 67.0,
             "Earth's main field at the surface (WMM): ~22 uT over the South Atlantic to ~67 uT near the magnetic poles"),
      {"raw_field_norm", "uT", 11.0, 167.5, 22.0, 67.0,
       "median |raw| of a compass: the 22-67 uT Earth field through a gain off by up to 2x, plus hard iron up to "
       "~1.5x the field; outside it the numbers are in another unit (mG, G, nT or counts)"},
      {"compass_offset", "uT", 0.0, 180.0, 0.0, 85.0,
       "hard iron of a mounted compass: ArduPilot refuses offsets over COMPASS_OFFS_MAX (1800 mG now, 850 mG in "
       "3.x); beyond that a magnet or steel sits on the sensor"},
      Effect("calibration_radius", "uT", 15.0, 100.0,
             "radius of the fitted sphere: the 22-67 uT Earth field times a raw sensor gain that may be ~30 % off"),
      Effect("soft_iron_diagonal", "1", 0.8, 1.2,
             "K(i,i) with det K = 1: steel near a compass changes an axis's gain by a few percent; 20 % is a wrong model"),
      Effect("soft_iron_off_diagonal", "1", 0.0, 0.2,
             "|K(i,j)|, det K = 1: soft iron couples axes by a few percent; 0.2 is a mis-mounted or damaged sensor"),
      Effect("soft_iron_condition", "1", 1.0, 2.0,
             "largest/smallest eigenvalue of K (and of A): soft iron stretches the field ellipsoid by a few percent; "
             "2 means an axis at half gain, a broken sensor or a wrong model"),
      // Dynamics channel.
      Effect("rotor_drag", "N/((rad/s)(m/s))", 0.0, 1e-3,
             "induced drag of a small rotor: ~1e-5..1e-4 N per (rad/s)(m/s); never negative"),
      Effect("ground_effect", "m", 0.0, 1.0, "effective rotor radius of a multirotor's ground effect: below a metre"),
      Effect("battery_sag", "Ohm", 0.0, 1.0, "pack plus wiring resistance is tens of milliohms; never negative"),
      Effect("motor_time_constant", "s", 0.0, 0.5, "small-motor speed time constants are 20-150 ms"),
      Effect("thrust_scale", "1", 0.5, 2.0, "thrust coefficient or mass within a factor of two of the configured one"),
      Effect("wind", "m/s", 0.0, 25.0, "a multirotor does not fly in mean winds above ~25 m/s"),
      // Logged inputs the replay and the identification drive their models with.
      Effect("bus_voltage_V", "V", 3.0, 100.0,
             "battery bus of a flying multirotor: one discharged lithium cell (3.0 V) up to ~24S heavy-lift packs; "
             "a flight median below it means no power monitor is connected"),
      Effect("velocity_accel_mismatch_mps2", "m/s^2", 0.0, 3.0,
             "rate of change of the logged velocity against the measured acceleration R*f + g over 1-s flight spans, "
             "RMS about its mean (a constant accelerometer bias drops out): a few degrees of attitude error "
             "(5 deg = 0.9 m/s^2) and vibration averaged over a second; 3 m/s^2 (0.3 g) means the velocity does not "
             "follow the aircraft (e.g. an EKF vertical velocity driven by a failing barometer)"),
      Effect("flight_power_per_weight_W_per_N", "W/N", 2.0, 100.0,
             "electrical power in flight per newton of weight: ideal induced power alone is sqrt(disc loading / 2 rho) "
             "= 3-13 W/N for disc loadings of 20-400 N/m^2, and rotors and motors waste a third or more; far above "
             "it no multirotor hovers (the weight is the base vehicle's where the log gives no mass)"),
      // Identified vehicle parameters (identify/, `hexsim identify`; names as in identify.json).
      // thrust_scale above is shared: the same k_T factor over the base vehicle.
      Effect("thrust_to_weight", "1", 1.2, 8.0,
             "all motors at full output over the weight: below 1.2 a multirotor cannot climb or control, racers reach ~8"),
      Effect("hover_output", "1", 0.05, 0.95,
             "motor output (0..1 of the PWM range) that holds the weight: above idle, with headroom left for control"),
      Effect("motor_time_constant_s", "s", 0.005, 0.3,
             "first-order motor-to-thrust lag: ~10 ms for racing motors, ~200 ms for large props; beyond 0.3 s no "
             "controller holds attitude"),
      Effect("vertical_drag_per_mass_1ps", "1/s", 0.0, 2.0,
             "axial (climb) drag per unit mass: induced and profile drag, ~0.1-0.5 /s; drag never pushes forward"),
      Effect("linear_drag_per_mass_1ps", "1/s", 0.0, 2.0,
             "horizontal linear drag (rotor drag included) per unit mass: ~0.1-0.5 /s on small multirotors; never negative"),
      Effect("quadratic_drag_per_mass_1pm", "1/m", 0.0, 1.0,
             "0.5*rho*Cd*A/m: ~0.01-0.1 /m for a 1-10 kg airframe; never negative"),
      Effect("yaw_torque_coefficient_m", "m", 0.002, 0.1,
             "rotor k_Q/k_T: ~0.01-0.03 m for 5-15 inch props (torque over thrust grows with the radius)"),
      Effect("yaw_damping_1ps", "1/s", 0.0, 10.0,
             "yaw-rate damping per unit inertia from rotor drag torque: a fraction of a 1/s to a few 1/s; never negative"),
      Effect("battery_ocv_cell_V", "V", 3.0, 4.35,
             "lithium cell open-circuit voltage: 3.0 V empty to 4.35 V (LiHV) full; cells = round(V / 3.8)"),
      Effect("battery_resistance_ohm", "ohm", 0.0, 1.0,
             "pack plus wiring internal resistance: tens of milliohms, a worn small pack a few hundred; never negative"),
      Effect("battery_charge_slope_V_per_Ah", "V/Ah", 0.0, 10.0,
             "open-circuit voltage falls as charge is drawn: ~0.5-5 V per Ah for 1-10 Ah packs; it never rises"),
      Effect("gyro_noise_radps", "rad/s", 0.0, 1.0,
             "logged gyro noise with vibration: MEMS white noise ~0.01 rad/s at the log rate; 1 rad/s is a broken mount"),
      Effect("accel_noise_mps2", "m/s^2", 0.0, 20.0,
             "logged accelerometer noise with vibration: ~0.1-3 m/s^2; ArduPilot calls 30 m/s^2 vibration clipping"),
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

bool IntervalPlausible(std::string_view name, double ci_lo, double ci_hi) {
  if (!(std::isfinite(ci_lo) && std::isfinite(ci_hi))) return false;
  const PhysicalRange* r = FindRange(name);
  return r == nullptr || (ci_hi >= r->lo && ci_lo <= r->hi);
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
