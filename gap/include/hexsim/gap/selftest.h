// `hexsim gap selftest`: a blind check of the diagnosis on pseudo-real logs. The simulator flies a
// mission with effects switched on that the diagnosis is not told about (it replays the log against
// the unmodified vehicle); classes clean / one effect / two effects / out-of-library.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hexsim/common/rng.h"
#include "hexsim/common/status.h"
#include "hexsim/gap/diagnose.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/sim/simulation.h"

namespace hexsim::gap {

// The compass the selftest injects into (0-based; quad_x's internal "mag2").
inline constexpr size_t kSelftestCompass = 1;

// One withheld effect. `magnitude` is in the unit the diagnosis reports for that effect
// (current_hard_iron µT/A, current_soft_iron 1/A Frobenius, misalignment deg, field_scale 1,
// local_anomaly µT, current_lag s, hard_iron_offset µT, throttle_hard_iron µT/throttle,
// temperature_drift µT/°C); out-of-library: current_exponent (exponent − 1), thermal_ramp (µT).
struct Injection {
  std::string effect;
  double magnitude = 0.0;
};

// In-library effects the selftest can inject, and each one's magnitude range for the "one effect"
// class (realistic sizes, each well above the measured detection threshold).
struct EffectRange {
  const char* effect;
  double lo, hi;
  bool signed_magnitude;
};
const std::vector<EffectRange>& InjectableEffects();
// The real profile's magnitudes: real aircraft sizes, nuisance-like effects beyond their normal ranges.
const std::vector<EffectRange>& RealInjectableEffects();
// Effects on the open-loop dynamics channel ("dynamics"), in the unit the diagnosis reports:
// rotor_drag N/((rad/s)(m/s)) (vehicle aero key in the truth), ground_effect effective radius m
// (per-rotor Cheeseman–Bennett in the truth, clamped at z = R/2), battery_sag Ω (log level: the
// logged voltage reads upstream of a resistance ΔR, so the ESCs see ΔR·I less), motor_time_constant
// extra τ at hover in s (the truth scales the rotor inertia: a speed-dependent lag), wind m/s (a
// constant world wind, seen through the full quadratic drag).
const std::vector<EffectRange>& InjectableDynamicsEffects();

// The truth setup of a trial: the vehicle/world/mission loaded (estimator truth, so the withheld
// compass effects do not change the flight) with the injections applied at the simulator level,
// plus the log-level injections applied by InjectIntoLog afterwards. `true_magnitude` receives the
// magnitude the diagnosis should report for each injection (same order).
struct Trial {
  sim::RunSetup truth;
  vehicle::VehicleParams configured;  // what the diagnosis is given
  std::vector<Injection> injections;
  std::vector<double> true_magnitude;
  // The compass latency the configured vehicle models (DiagnoseOptions::compass_latency_s): the
  // real profile's log latency, less an unmodelled part where the trial withholds one.
  double compass_latency_s = 0.0;
};

// The verdict an injected form must read: its own name, or the effect it is a form of
// (axis_scale_error → scale_error, unmodelled_latency → latency).
std::string TruthLabel(const std::string& injected);

struct SelftestOptions {
  // real: logs at real rates (10 Hz compass, attitude and current), a reference attitude with a slow
  // estimator error, residual calibration offsets and field-norm errors inside their normal ranges,
  // a stale current channel, compass latency, and out-of-library effect families drawn per trial;
  // ideal: exact logs (100 Hz rows, exact timing, the configured vehicle exact).
  std::string profile = "real";
  int trials = 100;                 // per class
  uint64_t seed = 1;
  std::string vehicle = "quad_x";
  // Empty: the profile's flight. Real: selftest_flight (climbs, descents, fast and slow legs in a
  // gusty breeze: a battery current that swings like a real flight's); ideal: square.
  std::string mission;
  std::string world = "default";
  double duration_s = 0.0;          // 0: the whole mission
  int threshold_trials = 20;        // per magnitude in the detection-threshold sweep
  bool thresholds_all_effects = false;  // false: current_hard_iron only
  DiagnoseOptions diagnose;
};

// Builds a trial's setups; the direction of each effect is drawn from `rng`.
Result<Trial> MakeTrial(const SelftestOptions& options, uint64_t seed, const std::vector<Injection>& injections,
                        RngStream* rng);
// Flies the trial and applies the log-level injections; returns the pseudo-real log.
Result<logs::FlightLog> FlyTrial(Trial* trial, RngStream* rng);

struct SelftestResult {
  nlohmann::json json;  // hexsim.gap_selftest/1
  std::string table;    // human-readable metrics
  bool targets_met = false;
};

// Runs trials 0 … n−1 of a selftest with `one` and returns their outcomes in trial order. Trials are
// independent (each has its own seed and random stream), so a runner may run them in any order or
// in parallel (e.g. forked workers: an outcome is plain JSON); the metrics do not depend on it.
using TrialFn = std::function<Result<nlohmann::json>(size_t trial)>;
using TrialRunner = std::function<Result<std::vector<nlohmann::json>>(size_t n, const TrialFn& one)>;

// Runs every class and the detection-threshold sweep. `progress` (may be null) is called per trial
// when the trials run here, one after the other; an empty `runner` means that.
Result<SelftestResult> RunSelftest(const SelftestOptions& options, void (*progress)(int done, int total) = nullptr,
                                   const TrialRunner& runner = {});

}  // namespace hexsim::gap
