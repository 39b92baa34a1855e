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

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "hexsim/common/status.h"
#include "hexsim/gap/compass_terms.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::gap {

struct DiagnoseOptions {
  int blocks = 20;                 // contiguous time blocks (CV folds = blocks / 2, bootstrap unit)
  int bootstrap_samples = 200;     // block bootstrap resamples for attribution probabilities
  double alpha = 0.01;             // family-wise false-alarm level of the gap test
  double explain_shrink = 0.2928932188134524;  // 1 − √0.5: removes half the held-out mean square
  double adequacy_ratio = 1.3;     // residual MS / high-frequency noise MS above this: structure left
  double min_duration_s = 20.0;    // shorter logs are not diagnosed
  int min_samples = 400;           // per channel
  uint64_t seed = 1;               // bootstrap resampling
  bool allow_field_extrapolation = true;  // dates outside 2015–2030 use the nearest WMM epoch
  // The compass the attitude reference fused (column prefix, e.g. "mag"); empty: decided from the
  // log meta (sim truth: none; imported log: the primary compass).
  std::string contaminating_compass = "auto";
  // Dynamics channel: height of the rotor plane above the ground when the vehicle stands on it
  // (ground effect uses z = CG height above the take-off point + this).
  double rotor_height_at_rest_m = 0.2;
  // Second wave (compass channels). Windows: --from/--to override the flight windows when from_s <
  // to_s. Nuisance terms: "normal" judges them against the plausibility table's normal ranges (real
  // logs); "exact" treats the configured vehicle as the calibrated truth, so any significant offset,
  // field or scale term is a finding (the ideal selftest).
  double from_s = 0.0, to_s = 0.0;
  std::string nuisance_ranges = "normal";
  // Structure counts when the held-out residual's power exceeds the noise floor by this fraction:
  // below a tenth of the noise power a structured part moves no heading by more than the noise does.
  double materiality = 0.1;
  bool timing_scan = true;  // compass latency and current staleness before fitting
  // The channels to diagnose, by name (mag, mag2, …, gyro, accel, dynamics); empty: every channel.
  // Each channel's bootstrap draws its own random stream (seed, channel name), so a channel's
  // result does not depend on which others are diagnosed.
  std::vector<std::string> channels;
  // The whole log for the in-flight compass model's absolute terms where `log` holds blocks out (the
  // identified-vehicle path); null: `log`. The model uses no vehicle, so nothing needs holding out.
  const logs::FlightLog* compass_model_log = nullptr;
};

struct CandidateResult {
  std::string effect;
  double probability = 0.0;          // block-bootstrap attribution probability
  double heldout_shrink = 0.0;       // 1 − RMS_after/RMS_before on held-out blocks, alone
  double p_value = 1.0;              // cluster-robust Wald test against no effect (family-corrected)
  double bic = 0.0;
  double magnitude = 0.0;            // one scalar figure (e.g. |d| µT/A), its unit in magnitude_unit
  double magnitude_ci95[2] = {0.0, 0.0};
  std::string magnitude_unit;
  nlohmann::json params = nlohmann::json::object();  // named physical parameters
  nlohmann::json ci95 = nlohmann::json::object();    // same names, [lo, hi]
  bool selected = false;             // part of the chosen model
  // Second wave: held-out share over the baseline, plausibility against realdata's table.
  double explained_share = 0.0;      // 1 − MS_after/MS_baseline on held-out blocks
  bool plausible = true;
  std::string physical_range;        // "lo..hi unit"
  int parameters = 0;
};

struct ChannelResult {
  std::string channel;  // FlightLog column prefix: mag, mag2, gyro, accel
  std::string unit;
  int samples = 0;
  double rms_before = 0.0;
  double noise_rms = 0.0;            // high-frequency (first-difference) noise estimate
  double noise_floor_ratio = 0.0;    // residual mean square / noise floor (1: nothing above the floor)
  bool gap_detected = false;
  double p_value = 1.0;
  double ljung_box_p = 1.0;
  bool reference_contaminated = false;
  nlohmann::json where = nlohmann::json::object();
  std::string verdict = "none";      // none | unexplained | ambiguous | <effect>
  std::string explanation;           // plain-language note (ambiguity manoeuvre, adequacy)
  std::vector<CandidateResult> candidates;  // best first
  double heldout_shrink = 0.0;       // of the selected model
  std::vector<std::string> not_available;  // candidate effects the log cannot support here
  // For plots: sample times, residual before/after (3 axes), the chosen regressor.
  std::vector<double> t_s, chosen_regressor;
  std::string chosen_regressor_name;
  std::vector<Eigen::Vector3d> residual_before, residual_after;
  // Second wave (compass channels; CONTRACTS.md "Second wave").
  double explained_share = 0.0;  // of the reported model
  nlohmann::json nuisance = nlohmann::json::object();
  nlohmann::json timing = nlohmann::json::object();
  nlohmann::json residual_left = nlohmann::json::object();
  nlohmann::json ground_vs_flight = nlohmann::json::object();
  std::vector<std::string> findings;  // nuisance and timing findings in plain language
  std::string headline;               // one line: the verdict and what to do
  std::optional<CompassTerms> absolute_terms;  // compass channels: the in-flight model's (compass_terms.h)
};

struct WindowSpan {
  double start_s = 0.0, end_s = 0.0;
  std::string kind, why;  // kind: flight | ground | excluded
};

struct PhaseSpan {
  double t0_s = 0.0, t1_s = 0.0;
  std::string phase;
};

struct GapReport {
  std::string log_name;
  std::string attitude_source;
  std::string field_model;
  Eigen::Vector3d earth_field_N_uT = Eigen::Vector3d::Zero();
  std::vector<ChannelResult> channels;
  std::vector<std::pair<std::string, std::string>> not_diagnosed;  // channel, why
  std::vector<PhaseSpan> phases;
  std::vector<std::string> effects_not_built;
  std::vector<WindowSpan> windows;
  std::string windows_source;
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

// gap.json (hexsim.gap/1).
nlohmann::json ToJson(const GapReport& report);
// The plain-language summary for stdout.
std::string Summary(const GapReport& report);
// One line per channel: the verdict with its magnitude, interval and share, and what to do.
std::string Headline(const ChannelResult& channel);
// The vehicle YAML text with the chosen effects added (compass keys, wiring segments, lag), and a
// comment block for those the vehicle schema cannot express.
Result<std::string> UpdatedVehicleYaml(const std::string& vehicle_yaml_text, const vehicle::VehicleParams& vehicle,
                                       const GapReport& report);

}  // namespace hexsim::gap
