// Sim-to-real gap diagnosis (issue 9, CONTRACTS.md "Gap diagnosis").
//
// Replay: the log's attitude (q_*), currents (current_A, motor_i_A) and throttle (control_u) drive
// the configured models to predict each measured channel; residual r = measured − predicted.
//   compass c:  H = R_SB·scale·K(I)·(R_NBᵀ·B_wmm + B_wiring(p_c, lagged I)) + β   (sensor frame)
//   gyro:       w_B = 2·Im(q_kᵀ⁻¹ ⊗ q_k+1)/dt (central difference of the logged attitude)
//   accel:      f_B = R_NBᵀ·(dv_N/dt − g_N)
// Where: residual RMS by flight phase, regime bin (current, throttle, speed, tilt) and band.
// Which: each candidate effect is a linear model of the residual (nonlinear parameters such as a lag
// are profiled over a grid); per time block the normal equations are accumulated once, so blocked
// cross-validation, the block bootstrap (attribution probability) and cluster-robust 95 % intervals
// are cheap. How much: held-out shrink 1 − RMS_after/RMS_before (RMS about zero).
// Gap exists: some candidate's parameters are non-zero by a cluster-robust (over time blocks) Wald
// test, Hotelling T² → F(p, G − p), Bonferroni over families; that candidate lowers the held-out
// residual; and the residual mean square exceeds the first-difference noise floor. The residual's
// whiteness (Ljung–Box) is reported only: the unresolvable part of the configured models (current
// logged at the row rate, compass sampled between rows) is coloured noise a real log has too.
// IMU channels: a latency within one IMU period is the known sample hold (no per-sample time stamp
// in the log) and is removed in the replay; the latency candidate reports the total.
// temperature_drift is d·(T − T_start) with no offset of its own (hard_iron_offset is separate).
#pragma once

#include <array>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexsim/common/status.h"
#include "hexsim/gap/compass_terms.h"
#include "hexsim/gap/effects.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::gap {

struct DiagnoseOptions {
  int blocks = 20;                 // contiguous time blocks (CV folds = blocks / 2, bootstrap unit)
  // A block covers at least min_block_s of flight, the in-flight compass model's shortest block
  // (long against the attitude reference's and the wiring's fast errors), and holds at least
  // min_block_samples samples: the in-flight model's 30 samples in its 6 blocks. The block count,
  // not the samples per block, sets the cluster-robust tests' degrees of freedom: a 1-2 Hz compass
  // cut into 30-sample blocks had 4 blocks and could not show a 3-parameter effect at all.
  double min_block_s = 2.0;
  int min_block_samples = 5;
  int bootstrap_samples = 200;     // block bootstrap resamples for attribution probabilities
  double alpha = 0.01;             // family-wise false-alarm level of the gap test
  // The verdict names an effect outright when it removes at least this share of the held-out
  // structure above the noise floor (ExplainedShare): more than any other part can hold, so it is
  // the largest cause. A material effect below it is the headline marked partial (CONTRACTS.md).
  double headline_share = 0.5;
  double min_duration_s = 20.0;    // shorter logs are not diagnosed
  // Gyro, accel and dynamics channels: the fewest samples per channel. Compass channels derive
  // theirs from what their analysis fits (gap/src/channels.h CompassMinSamples: 2·10·unknowns/3,
  // 120 for the 6-term baseline with a quad's 12-term per-motor candidate) unless the in-flight
  // model fits them (its own minimum).
  int min_samples = 400;
  uint64_t seed = 1;               // bootstrap resampling
  // Channels diagnosed at once, each on its own thread (1: in turn). Every channel draws from its
  // own random stream and reads only the shared replay, so the report is the same for any count.
  int threads = 1;
  bool allow_field_extrapolation = true;  // dates outside 2015–2030 use the nearest WMM epoch
  // The compass the attitude reference fused (column prefix, e.g. "mag"); empty: decided from the
  // log meta (sim truth: none; imported log: the primary compass).
  std::string contaminating_compass = "auto";
  // Compass channels. Windows: --from/--to override the flight windows when from_s < to_s.
  // Nuisance terms: "normal" judges them against the plausibility table's normal ranges (real
  // logs); "exact" treats the configured vehicle as the calibrated truth, so any significant offset,
  // field or scale term is a finding (the ideal selftest).
  double from_s = 0.0, to_s = 0.0;
  std::string nuisance_ranges = "normal";
  // An effect (or structure) is material when it removes at least this fraction of the noise
  // floor's power on held-out blocks: below a tenth of the noise power a structured part moves no
  // heading by more than the noise does.
  double materiality = 0.1;
  // Compass channels: an effect is material too when its field turns the heading by at least this
  // RMS over the flight (degrees, the low end of its 95 % interval; verdict.h HeadingTurnOf), however
  // noisy the sensor. The attitude filter averages a compass's noise but follows a heading turned
  // with the current, so a field that turns it matters to the user even where the sensor's noise
  // power dwarfs it (a noisy internal compass). 1°: the heading a GNSS-aided yaw estimate resolves in
  // steady flight, below it a turn is lost in the estimate's own error. 0: noise power only.
  double material_heading_deg = 1.0;
  // Inertial and dynamics channels: an effect is material when it also removes this share of the
  // held-out structure above the floor (a replay's unresolvable part, commands between log rows,
  // is not a gap, and a tenth is the smallest part the CV folds resolve on a 20-block log).
  double min_effect_share = 0.1;
  // Inertial channels: the residual's mean square must exceed the floor by 1 + floor_margin_z/√n
  // (n residual components): a z-score of the mean square's sampling spread, 6 so that a clean
  // replay (its floor estimated from the same residual) never passes it by chance.
  double floor_margin_z = 6.0;
  // Dynamics channel: its floor (the residual's variance above ~4 Hz) must not exceed the measured
  // accelerometer's own variance there by more than this factor. A replay whose fast response is
  // right removes part of what the sensor sees there and adds nothing; a floor twice the sensor's own
  // means the replay's fast error is at least as large as everything the accelerometer measures at
  // those frequencies: the floor is the configured vehicle's error, not noise (model mismatch), and
  // "no gap" cannot be told against it (a 12S quad replayed as quad_x: floor 26 m/s^2).
  double max_floor_over_measured = 2.0;
  // A second effect joins the first when the pair lowers the held-out SSE below the first's by at
  // least one standard error of the fold differences (one-standard-error rule) and is material.
  // Ambiguous: two as-simple effects within one standard error of each other, neither nesting the other.
  bool timing_scan = true;  // compass latency and current staleness before fitting
  // The compass latency the vehicle file models (s). hexsim's simulated compasses are stamped at
  // their measurement epoch, so 0; a measured latency whose interval excludes it is an effect (the
  // gap is relative to the simulator), named when its alignment removes `materiality` of the noise
  // floor's power held out, or min_effect_share of the unaligned structure (the compass rule, MaterialWhy).
  double compass_latency_s = 0.0;
  // The channels to diagnose, by name (mag, mag2, …, gyro, accel, dynamics); empty: every channel.
  // Each channel's bootstrap draws its own random stream (seed, channel name), so a channel's
  // result does not depend on which others are diagnosed.
  std::vector<std::string> channels;
  // The whole log for the in-flight compass model's absolute terms where `log` holds blocks out (the
  // identified-vehicle path); null: `log`. The model uses no vehicle, so nothing needs holding out.
  const logs::FlightLog* compass_model_log = nullptr;
};

// A 95 % interval [lo, hi].
struct Interval {
  double lo = 0.0, hi = 0.0;
};

// Named physical parameters of a fit (name → value) and their 95 % intervals (same names).
using Params = std::map<std::string, double>;
using ParamIntervals = std::map<std::string, Interval>;
// "name=value, …" (4 significant digits), for plain-language notes.
std::string ParamsText(const Params& params);

struct CandidateResult {
  std::string effect;
  Effect id = Effect::kNone;         // the registered effect (effects.h); kNone for a joint "a+b"
  double probability = 0.0;          // block-bootstrap attribution probability (NaN: not bootstrapped)
  double heldout_shrink = 0.0;       // 1 − RMS_after/RMS_before on held-out blocks, alone
  double p_value = 1.0;              // cluster-robust Wald test against no effect (family-corrected)
  double bic = 0.0;
  double magnitude = 0.0;            // one scalar figure (e.g. |d| µT/A), its unit in magnitude_unit
  double magnitude_ci95[2] = {0.0, 0.0};
  std::string magnitude_unit;
  Params params;                     // named physical parameters
  ParamIntervals ci95;               // same names
  bool nuisance_term = false;        // a term of the nuisance baseline (offset, anomaly, field scale)
  bool selected = false;             // part of the chosen model (listed in ChannelResult::effects)
  // Held-out share over the baseline (ExplainedShare), plausibility against realdata's table.
  double explained_share = 0.0;
  bool plausible = true;
  std::string physical_range;        // "lo..hi unit"
  int parameters = 0;
};

// One material effect of the decomposition (CONTRACTS.md "The verdict is a decomposition"), in the
// order of its explained share.
struct EffectShare {
  std::string effect;
  Effect id = Effect::kNone;
  double magnitude = 0.0;
  Interval ci95;
  std::string unit;                  // the magnitude's physical unit (µT/A, s, 1, …)
  std::string autopilot_unit;        // the autopilot's unit where one exists (mG/A for COMPASS_MOT), else empty
  double autopilot_factor = 1.0;     // autopilot value = factor · magnitude
  double explained_share = 0.0;      // alone, over the baseline (ExplainedShare)
  std::string source;                // "fit" (a library candidate), "timing" (the latency scan), "vehicle" (a
                                     // baseline term against the vehicle file), "nuisance"
};

// Where the residual sits: RMS by flight phase, by regime quartile, by frequency band.
struct RegimeBin {
  std::string bin;  // low | mid-low | mid-high | high
  double rms = 0.0, samples = 0.0;
};
struct RegimeSplit {
  std::array<double, 3> edges = {0.0, 0.0, 0.0};
  std::vector<RegimeBin> bins;
};
struct Where {
  bool present = false;
  std::map<std::string, double> rms_by_phase;
  std::string phase_concentrated;
  std::map<std::string, RegimeSplit> regime;  // current, throttle, speed, tilt
  std::string regime_concentrated;            // e.g. "high current", or "uniform"
  double band_below_0p2Hz = 0.0, band_0p2_to_2Hz = 0.0, band_above_2Hz = 0.0;  // shares of the mean square
  std::string band_concentrated;
  double rms = 0.0;
};

// What the reported model leaves: its share of the structure above the floor, dominant frequency,
// the share of its mean square a straight line in time holds (trend), isolated spikes, and where.
struct ResidualLeft {
  bool present = false;
  double share = 0.0, dominant_freq_Hz = 0.0, trend = 0.0;
  int spikes = 0;
  std::string concentrated;  // phase, regime
};

// The nuisance baseline's fit (compass channels): r = β + M·R_NBᵀ·δB_N.
struct Nuisance {
  bool present = false;
  Eigen::Vector3d offset_uT = Eigen::Vector3d::Zero();
  Interval offset_ci95_uT;  // of |β|
  double field_scale = 1.0, field_scale_horizontal = 1.0;
  Eigen::Vector3d field_vector_N_uT = Eigen::Vector3d::Zero(), field_prior_N_uT = Eigen::Vector3d::Zero(),
                  field_correction_N_uT = Eigen::Vector3d::Zero();
  double field_direction_error_uT = 0.0;
  // Where field_prior_N_uT comes from: "WMM..." (the field model at the log's place and date) or
  // "fitted freely ..." (no place and date: the in-flight model's free Earth field, as hexsim
  // calibrate --method flight); against a fitted field a uniform scale of the compass is not measured.
  std::string field_source;
  bool undone_compensation = false;
  std::string ranges;                            // normal | exact
  double current_split_exponent = std::nan("");  // NaN: not fitted (per-motor currents, or no current)
};

// A lag estimate of the timing scan.
struct LagReport {
  bool present = false;
  double value_s = 0.0;
  Interval ci95_s;
  std::string against;  // what it is measured against: "attitude (q_*)", "control_u"
  bool resolved = false, plausible = false;
  double explained_share = std::nan("");  // latency: held-out share its alignment removes
  double applied_shift_s = std::nan("");  // staleness: the shift the replay applied
};
struct Timing {
  LagReport latency;            // compass latency against the attitude
  LagReport current_staleness;  // logged current against the throttle
  // A current-driven field's lag behind the logged current, against "current_A": the timing scan's
  // (ScanCurrentFieldLag: profile over 0..2 s, block bootstrap; resolved when bounded and clear of
  // zero; explained_share NaN), whatever effect is named, as the latency is; where current_lag is
  // selected, that effect's τ (its interval after the plug-ins) and its share.
  LagReport current_field_lag;
};

// ΔB/ΔI between flight and ground with the flight's baseline (compassmot's principle).
struct GroundVsFlight {
  bool present = false;
  int ground_samples = 0;
  Eigen::Vector3d delta_B_uT = Eigen::Vector3d::Zero();
  double delta_I_A = 0.0;
  double mG_per_A = std::nan("");  // NaN: the current step is too small
};

struct ChannelResult {
  std::string channel;  // FlightLog column prefix: mag, mag2, gyro, accel
  int vehicle_compass = 0;  // compass channels: the vehicle file's compass compared with (1-based; 0: none)
  std::string unit;
  int samples = 0;
  double rms_before = 0.0;
  double noise_rms = 0.0;            // the channel's noise floor (RMS per component; ExplainedShare)
  double noise_floor_ratio = 0.0;    // residual mean square / noise floor (1: nothing above the floor)
  // Dynamics channel: the measured accelerometer's own RMS above the floor window (0: not measured).
  // A replay whose fast response is right leaves at most about this as its floor; a floor above
  // DiagnoseOptions::max_floor_over_measured times it is the replay's own error (model mismatch).
  double measured_floor_rms = 0.0;
  bool gap_detected = false;
  double p_value = 1.0;
  double ljung_box_p = 1.0;
  bool reference_contaminated = false;
  Where where;
  std::string verdict = "none";      // none | unexplained | ambiguous | <effect>
  bool partial = false;              // the headline effect's share is below headline_share
  std::string explanation;           // plain-language note (ambiguity manoeuvre, adequacy)
  std::vector<CandidateResult> candidates;  // best first (every fitted candidate; printing is filtered)
  std::vector<EffectShare> effects;  // the material effects, by explained share, largest first
  double heldout_shrink = 0.0;       // of the selected model
  std::vector<std::string> not_available;  // candidate effects the log cannot support here
  // For plots: sample times, residual before/after (3 axes), the chosen regressor.
  std::vector<double> t_s, chosen_regressor;
  std::string chosen_regressor_name;
  std::vector<Eigen::Vector3d> residual_before, residual_after;
  double explained_share = 0.0;  // of the reported model (all its effects together)
  Nuisance nuisance;
  Timing timing;
  ResidualLeft residual_left;
  GroundVsFlight ground_vs_flight;
  std::vector<std::string> findings;  // nuisance and timing findings in plain language
  std::string headline;               // one line: the verdict and what to do
  std::optional<CompassTerms> absolute_terms;  // compass channels: the in-flight model's (compass_terms.h)
};

struct WindowSpan {
  double start_s = 0.0, end_s = 0.0;
  std::string kind, why;  // kind: flight | ground | excluded
  bool on_ground = false;  // a flight window whose height never climbs (realdata::Window::on_ground)
};

struct PhaseSpan {
  double t0_s = 0.0, t1_s = 0.0;
  std::string phase;
};

// Which compass of the vehicle file a log compass is compared with (the vehicle's compass
// `vehicle_compass`, 1-based, in the file's order).
struct CompassPair {
  std::string channel;      // the log's column prefix: mag, mag2, …
  int vehicle_compass = 0;  // 1-based index in the vehicle file's compasses
  bool external = false;    // the vehicle file's flag of that compass
};
struct CompassMapping {
  std::string method = "index";  // external_flag | index
  std::string why;
  std::vector<CompassPair> pairs;
};

struct GapReport {
  std::string log_name;
  CompassMapping compass_mapping;
  std::string attitude_source;
  std::string field_model;
  Eigen::Vector3d earth_field_N_uT = Eigen::Vector3d::Zero();
  std::vector<ChannelResult> channels;
  std::vector<std::pair<std::string, std::string>> not_diagnosed;  // channel, why
  std::vector<PhaseSpan> phases;
  std::vector<std::string> effects_not_built;
  std::vector<WindowSpan> windows;
  std::string windows_source;
  double headline_share = 0.5;  // DiagnoseOptions::headline_share the verdicts used
};

// Flight phases per log row: ground, takeoff, hover, climb, cruise, descent, landing, excluded
// (realdata's flight windows and phase labels, segments of at least 2 s).
std::vector<std::string> ClassifyPhases(const logs::FlightLog& log);

// The whole diagnosis. Bad input (no rows, no t_s) is kBadInput; missing channels or a short log are
// not: they are listed in not_diagnosed.
Result<GapReport> Diagnose(const logs::FlightLog& log, const vehicle::VehicleParams& vehicle,
                           const DiagnoseOptions& options = {});

// First-order time constant of the configured rotor speed at hover, τ = J/(K_t²/R + 2·k_Q·ω_h)
// (k_T·ω_h² = m·g/n); the motor_time_constant candidate reports the extra τ at this point.
double HoverRotorTimeConstant_s(const vehicle::VehicleParams& vehicle);

// gap.json (hexsim.gap/1): ToJson in hexsim/gap/json.h (serialisation beside the types, not in them).
// The plain-language summary for stdout.
std::string Summary(const GapReport& report);
// One line per channel: the verdict with its magnitude, interval and share, and what to do.
std::string Headline(const ChannelResult& channel);
// The nuisance's fitted field against the field model, as one phrase: its horizontal part (which
// turns with every heading) always; the norm only where its ratio lies in field_scale's physical
// range (in a nearly level flight the vertical field trades with the z offset and the norm is not
// resolved; a number outside the range is never printed as a finding).
std::string FieldScaleText(const Nuisance& nuisance);
// The vehicle YAML text with the chosen effects added (compass keys, wiring segments, lag), and a
// comment block for those the vehicle schema cannot express.
Result<std::string> UpdatedVehicleYaml(const std::string& vehicle_yaml_text, const vehicle::VehicleParams& vehicle,
                                       const GapReport& report);

}  // namespace hexsim::gap
