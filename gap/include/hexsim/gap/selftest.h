// `hexsim gap selftest`: a blind check of the diagnosis on pseudo-real logs. The simulator flies a
// mission with effects switched on that the diagnosis is not told about (it replays the log against
// the unmodified vehicle); classes clean / one effect / two effects / out-of-library.
#pragma once

#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "hexsim/common/rng.h"
#include "hexsim/common/status.h"
#include "hexsim/gap/diagnose.h"
#include "hexsim/gap/effects.h"
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

// The verdict an injected form must read: the registered effect of its name, or the effect it is a
// form of (axis_scale_error → scale_error, unmodelled_latency → latency); Effect::kNone for a form
// no registered effect names (out of library: current_exponent, thermal_ramp).
Effect TruthLabel(const std::string& injected);

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

// A withheld effect as a trial record keeps it: the injected name and its truth label (TruthLabel).
struct InjectedEffect {
  std::string name;
  Effect label = Effect::kNone;
};

// What the diagnosis reported of an injected effect: its candidate on the channel.
struct ReportedEffect {
  Effect effect = Effect::kNone;
  double magnitude = 0.0;  // in the effect's unit (EffectInfo::unit)
  std::array<double, 2> ci95 = {0.0, 0.0};
  double explained_share = 0.0;
  bool selected = false;
};

// The lag candidate's fit on a lagged form (current_power_lag), beside the form's true lag.
struct LagFit {
  double tau_s = 0.0;
  std::array<double, 2> ci95_s = {0.0, 0.0};
  bool selected = false, plausible = false;
  bool named = false;    // the verdict is current_lag
  bool covered = false;  // the lag's interval holds the true lag
};

// One class trial: the truth beside what the diagnosis reported of it.
struct ClassTrialRecord {
  std::string family;  // the out-of-library family or the form beyond the library ("": none)
  std::vector<InjectedEffect> injected;
  std::vector<double> true_magnitude;  // per injection, in the unit the diagnosis reports
  std::string verdict;                 // the channel's verdict (ChannelResult::verdict)
  bool gap_detected = false;
  double heldout_shrink = 0.0;
  double explained_share = 0.0;
  std::string selected;  // the selected candidates, joined by '+'
  // A compass channel flagged a gap (clean logs: any compass is a false alarm).
  bool any_compass_alarm = false;
  std::optional<bool> dynamics_detected;  // clean logs, where the dynamics channel was diagnosed
  bool left_reported = false;  // structure no candidate describes, reported beside the headline
  // Not a confident answer: unexplained, ambiguous, partial or the leftover reported.
  bool not_confident = false;
  bool all_in_effects = false;  // every injected effect is a material effect of the channel
  // A family or form: the verdict is one of the names it is a form of; right (named right, or not
  // confident).
  std::optional<bool> named_right, judged_right;
  std::optional<double> true_lag_s;  // a lagged form's time constant
  std::optional<LagFit> lag_fit;
  std::vector<ReportedEffect> reported;  // one per injected effect the channel has a candidate of
  // One-effect classes: the true effect's held-out explained share (0 when not reported), and
  // whether its reported interval holds the truth (empty: no candidate of the injected form).
  std::optional<double> true_share;
  std::optional<bool> covered;
};

// One trial of the detection-threshold sweep of current_hard_iron.
struct ThresholdTrialRecord {
  double magnitude_uT_per_A = 0.0;  // the true magnitude
  bool flagged = false;
  std::string verdict;  // "not diagnosed" when the channel was not
};

using TrialRecord = std::variant<ClassTrialRecord, ThresholdTrialRecord>;

// (hits, trials) of a count.
struct Tally {
  int hits = 0, trials = 0;
};

// A class's metrics, summed over its trials.
struct SelftestClassStats {
  int n = 0, top1 = 0, detected = 0, not_confident = 0, confident_wrong = 0, covered = 0, coverage_n = 0;
  int any_compass_alarm = 0;
  int all_in_effects = 0;                  // two effects: both listed in `effects`
  int judged_right = 0, named_right = 0;   // forms: right (named right or not confident), named right
  int left_reported = 0;                   // the leftover reported beside the headline
  int dynamics_alarm = 0, dynamics_n = 0;  // clean logs: gap flagged on the dynamics channel
  std::vector<double> shrink, share;
  std::map<std::string, Tally> per_effect;            // effect → top1; a family → not confident
  std::map<std::string, Tally> per_effect_coverage;   // effect → covered
  std::map<std::string, Tally> per_form_named;        // form → named right
  std::map<std::string, Tally> per_form_right;        // form → judged right
  std::map<std::string, Tally> per_form_lag_named;    // lagged form → named current_lag
  std::map<std::string, Tally> per_form_lag_covered;  // lagged form → its lag's interval holds the truth
  std::map<std::string, int> verdicts;                // verdict → count
  double Rate(int k) const { return n > 0 ? static_cast<double>(k) / n : 0.0; }
  double MedianShrink() const;
  double MedianShare() const;
  double Coverage() const { return coverage_n > 0 ? static_cast<double>(covered) / coverage_n : 0.0; }
};

// The detection threshold of current_hard_iron: the smallest magnitude flagged in ≥ 90 % of trials
// (and at every larger magnitude of the grid); NaN: not reached.
struct SelftestThreshold {
  std::vector<double> grid_uT_per_A;
  std::vector<double> flagged_rate;  // per grid magnitude
  double value_uT_per_A = std::nan("");
};

struct SelftestResult {
  SelftestOptions options;  // as run (the profile's mission filled in)
  std::string channel;      // the selftest compass' channel
  std::vector<std::string> classes;
  std::map<std::string, SelftestClassStats> stats;  // per class
  SelftestThreshold threshold;
  double single_top1 = 0, overall_top1 = 0, false_alarm = 0, not_confident = 0, coverage = 0;
  double dynamics_false_alarm = 0;
  std::map<std::string, bool> targets;                          // target → met
  std::optional<std::map<std::string, bool>> dynamics_targets;  // none: not run on this profile
  bool compass_targets_met = false, dynamics_targets_met = false;
  bool targets_met = false;  // both
  std::vector<TrialRecord> trials;        // every trial, in trial order
  std::vector<std::string> trial_classes; // each trial's class ("threshold" for the sweep)
  std::string table;                      // human-readable metrics
};
// hexsim.gap_selftest/1: ToJson in hexsim/gap/selftest_json.h (serialisation beside the types).

// Runs trials 0 … n−1 of a selftest with `one` and returns their records in trial order. Trials are
// independent (each has its own seed and random stream), so a runner may run them in any order or
// in parallel (e.g. forked workers, each record passed back through selftest_json.h's serialiser);
// the metrics do not depend on it.
using TrialFn = std::function<Result<TrialRecord>(size_t trial)>;
using TrialRunner = std::function<Result<std::vector<TrialRecord>>(size_t n, const TrialFn& one)>;

// Runs every class and the detection-threshold sweep. `progress` (may be null) is called per trial
// when the trials run here, one after the other; an empty `runner` means that.
Result<SelftestResult> RunSelftest(const SelftestOptions& options, void (*progress)(int done, int total) = nullptr,
                                   const TrialRunner& runner = {});

}  // namespace hexsim::gap
