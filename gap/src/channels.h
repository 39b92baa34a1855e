// Replay of a FlightLog into per-channel residuals and the candidate effects' regressors (private).
#pragma once

#include <cmath>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "hexsim/gap/diagnose.h"
#include "hexsim/gap/effects.h"
#include "hexsim/magnetics/current_field.h"
#include "hexsim/realdata/timing.h"
#include "hexsim/realdata/windows.h"

namespace hexsim::gap::internal {

using Vec3 = Eigen::Vector3d;
using Mat3X = Eigen::Matrix<double, 3, Eigen::Dynamic>;

// One candidate model: per sample a 3×p block of regressors; coefficient j times scale[j] is the
// physical parameter names[j].
struct Candidate {
  std::string effect;
  Effect id = Effect::kNone;  // the registered effect of that name (kNone: an internal fit)
  std::string regressor_name;  // for the "residual vs regressor" plot
  std::vector<std::string> names;
  std::vector<double> scale;
  std::vector<Mat3X> X;
  std::vector<double> regressor;  // scalar regressor per sample for the plot (may be empty)
  double grid_value = 0.0;        // profiled nonlinear parameter (lag τ), else 0
  std::string grid_name;          // e.g. "tau_s"
  double grid2_value = 0.0;       // a second profiled parameter (the lagged current's exponent), else 0
  std::string grid2_name;         // e.g. "exponent"; empty: none
  std::string magnitude_unit;
  int magnitude_params = -1;  // the magnitude uses the first this many parameters (-1: all)
  // The columns it joins another effect's fit with (Join), where X are taken beside a field that
  // effect describes (verdict.cc BesideDrive keeps its own columns here); empty: X.
  std::vector<Mat3X> X_joint;
  // The parameters past magnitude_params that describe the field's form rather than its size (a
  // share of the vehicle file's per-motor shape): each one's physical range. A member whose fitted
  // form lies outside it describes no field of that form and is not the family's (ReportedMember).
  struct FormRange {
    int param = 0;
    double lo = 0.0, hi = 0.0;
  };
  std::vector<FormRange> form_ranges;
  int p() const { return static_cast<int>(names.size()); }
};

// A candidate with its parameter names, scales, magnitude unit and plot regressor; the caller adds X.
inline Candidate MakeCandidate(std::string effect, std::vector<std::string> names, std::vector<double> scale,
                               std::string unit, std::string regressor_name = "") {
  Candidate c;
  c.effect = std::move(effect);
  c.id = EffectFromName(c.effect);
  c.names = std::move(names);
  c.scale = std::move(scale);
  c.magnitude_unit = std::move(unit);
  c.regressor_name = std::move(regressor_name);
  return c;
}

inline constexpr int kFlexFieldParams = 9;

// The replayed channel.
struct ChannelData {
  std::string name, unit;
  bool bias_nuisance = false;  // the configured noise model has a constant bias: intercept always in
  std::vector<double> t;
  std::vector<Vec3> y;                 // residual measured − predicted
  std::vector<int> row;                // nearest log row (phase, regimes)
  std::vector<Candidate> candidates;   // families share `effect`
  std::vector<std::string> not_available;
  // Known sample hold (IMU channels): the sensor sample the log row carries is up to one sensor
  // period old, so a latency in [0, known_hold_max_s] is part of the configured model; the replay
  // removes the fitted hold (known_hold_s) and the latency candidate measures only the excess.
  double known_hold_s = 0.0, known_hold_max_s = 0.0;
  // "Explained" measured on the residual above the noise floor: an effect confined to some flight
  // phases (ground effect near the ground, a motor lag during throttle changes) removes most of the
  // structured residual but little of the whole one (noise included).
  bool explain_above_noise = false;
  // The measured signal itself at the channel's samples (dynamics channel: the accelerometer; empty:
  // not kept). Its own variance above the floor window bounds what a right replay leaves there: a
  // replay whose fast part is right removes some of it, one whose fast part is wrong adds its error.
  std::vector<Vec3> measured;
  std::string note;  // appended to the channel's explanation (e.g. fitted nuisance parameters)
  // The channel replayed with its between-row inputs read at half the log's row rate, one per phase
  // (even rows kept, odd rows kept; dynamics channel; empty: none): the residual, and the candidates
  // whose regressors come from the replay's rotor speeds or from a fit to the residual itself,
  // rebuilt from that replay (thrust_scale, rotor_drag, ground_effect, wind). Each candidate's fit
  // there beside its fit to y measures what the log's row rate leaves undetermined (AnalyzeInertial
  // adds it to the candidate's interval); a candidate not rebuilt is refitted with its own regressors.
  struct RowRateVariant {
    std::vector<Vec3> y;
    std::vector<Candidate> candidates;
  };
  std::vector<RowRateVariant> half_rate;
  // The configured sensor's bias random walk, per √s (dynamics channel; 0: none). The intercept
  // removes a constant bias only; what the walk adds moves each fit by an amount BiasWalkCov states
  // (AnalyzeInertial adds it to the candidate's interval).
  double bias_walk_per_sqrt_s = 0.0;
  // Compass channels: the nuisance baseline fitted under every candidate (its
  // coefficients are findings, never effects), the WMM prior, the currents and throttle per sample.
  bool compass = false;
  Candidate baseline;
  // Library-free regressors over the baseline (detection.cc): smooth functions of the predicted
  // field, current, throttle and time, never a verdict.
  Candidate flexible;  // its first kFlexFieldParams columns: the field matrix; then current, throttle
  Vec3 field_N_uT = Vec3::Zero();
  bool undone_compensation = false;
  std::vector<double> current_A, throttle;
};

// The log columns the replay reads (pointers into the log).
struct LogInputs {
  std::vector<const std::vector<double>*> q;
  // The battery current at the row times, rebuilt from its own samples (a sample-and-hold channel:
  // realdata::FirstAppearances), owned here.
  std::shared_ptr<const std::vector<double>> current_rows;
  std::vector<double> current_samples_t, current_samples_v;  // its samples, each where it first appears
  const std::vector<double>* current = nullptr;
  // Why `current` is null though the log has a current_A column: the import's check
  // (logs::CurrentSensorOf) found the sensor unusable; no current-based family is fitted then.
  std::string current_unusable_why;
  bool current_usable = true;  // the import's check (logs::CurrentSensorOf): false with the reason above
  std::vector<const std::vector<double>*> motor_A;
  std::vector<const std::vector<double>*> motor_u;
  const std::vector<double>* control_u = nullptr;
  const std::vector<double>* temp = nullptr;
  bool has_attitude = false;
};

// How the motors share the battery current in a log without per-motor currents: I_i ∝ u_i^p over
// the motor outputs u_i. p = 3 is the static law (a motor's DC power τ·ω ∝ ω³, ω ∝ u) and bounds it
// above; p = 0, the equal split, is what a log without outputs allows and bounds it below. The real
// currents' differences lie between: thrust-linearised outputs, motor losses, the motors' dynamics
// and the rotors' inflow all lower it (measured on hexsim's quad: the cubic split's per-motor error
// grows with tilt², exactly the shape of the baseline's vertical-field column, which absorbed it,
// 0.27 µT in D; the equal split, 0.05 µT). Diagnose fits p to the logged battery current against
// the outputs (FitShareExponent: the law's common mode; hexsim's quad reads 2.0, log171 1.7);
// kShareExponent, the middle of the range, where it cannot. PropagatePlugIns refits at both ends of the range.
constexpr double kShareExponentLo = 0.0, kShareExponentHi = 3.0;
constexpr double kShareExponent = 0.5 * (kShareExponentLo + kShareExponentHi);

// Whether the replay splits the logged battery current over the motors by their outputs: a battery
// current, no per-motor currents, and an output per rotor.
inline bool SplitsBatteryCurrent(const LogInputs& in, const vehicle::VehicleParams& v) {
  return in.current != nullptr && in.motor_A.empty() && !v.rotors.empty() && in.motor_u.size() == v.rotors.size();
}

// The vehicle file models a current field: any wire segment or motor dipole.
inline bool HasWiring(const vehicle::VehicleParams& v) { return !v.wiring.segments.empty() || !v.wiring.dipoles.empty(); }

// Which of current_lag's members a replay builds: every member, or the lag profile (every τ) of one
// form: the configured-wiring member, or the free member at one exponent.
struct LagMembers {
  enum class Form { kAll, kWiring, kFree } form = Form::kAll;
  double exponent = 1.0;  // kFree: the free member's exponent (kLagExponents)
};

// How a compass is replayed: its timing, which rows, how much is built.
struct CompassReplayOptions {
  double latency_s = 0.0;        // the sample stamped t measured the field at t − latency_s
  double current_shift_s = 0.0;  // the prediction's current is I(t − latency_s + current_shift_s)
  // current_hard_iron's and current_soft_iron's members: the logged current I(t − latency_s) and,
  // for each shift here (ascending; the in-flight model's grid, realdata::CurrentShiftGrid), the
  // current aligned by it, I(t − latency_s + shift). Empty: the logged current only.
  std::vector<double> member_shifts_s;
  double LongestMemberShift_s() const { return member_shifts_s.empty() ? 0.0 : member_shifts_s.back(); }
  double share_exponent = kShareExponent;  // the motors' current split (see kShareExponent), in [0, 3]
  const std::vector<realdata::RowKind>* row_kind = nullptr;  // null: every row
  realdata::RowKind want = realdata::RowKind::kFlight;
  bool baseline_only = false;   // the timing scan: baseline and the aligned current_hard_iron only
  bool library_free = true;     // build the library-free set (detection)
  bool calibrated_log = false;  // the autopilot calibrated the logged values: no configured hard/soft iron
  // The attitude is an estimator's that fuses a compass (ReplayResult::contaminated): build
  // reference_yaw, its heading error in proportion to the current (AddReferenceYaw).
  bool reference_yaw = false;
  // The attitude reference fused this compass: its heading follows this compass's, so a rotation of
  // the compass about the vertical turns the reference with it and leaves no residual (a mounting
  // yaw is not identifiable here; what a fitted one would take is the reference's own heading
  // error). The misalignment family then holds only the tilt angles φx, φy.
  bool fused_by_reference = false;
  // Refits of reported members only (PropagatePlugIns): build just these families (empty: every
  // family), and of current_lag just the reported form's lag profile (LagMembers).
  std::vector<Effect> only_families;
  LagMembers lag_members;
  // Refits: of current_hard_iron's and current_soft_iron's members only those at these shifts (the
  // reported members'; empty: every member). The samples stay those of every member (LongestMemberShift_s).
  std::vector<double> only_member_shifts_s;
};

// current_lag's free member: a field the vehicle file does not model that follows the current
// through a first-order lag and may grow faster than linearly,
//   r = d·(lp_τ(I)/I_ref)^p,  d a free direction and size (µT at I_ref, the flight's median current),
// I the prediction's aligned current, τ in {0} ∪ kLagGrid_s and p in kLagExponents, both profiled
// (the unlagged members τ = 0 are the family's no-lag reference: a lag is resolved only where a
// lagged member beats them, see Attribute). Physical range of the exponent: kLagExponentLo..Hi.
// `exponent`: only the members of that exponent (NaN: every exponent of kLagExponents).
void AddLaggedCurrentField(ChannelData* ch, double exponent = std::nan(""));

// Builds every channel the log and the vehicle support; the rest go to not_diagnosed.
struct ReplayResult {
  std::vector<ChannelData> channels;
  std::vector<std::pair<std::string, std::string>> not_diagnosed;
  std::string attitude_source;
  std::string contaminated;  // compass column prefix fused by the attitude reference, or empty
  std::string field_model;
  Vec3 earth_field_N_uT = Vec3::Zero();
  // No usable place and date (no GPS fix): each compass is replayed against an Earth field fitted
  // freely from its own flight (FreeEarthField); field_free_why says why the model was not used.
  bool field_free = false;
  std::string field_free_why;
  std::vector<size_t> compasses;  // vehicle compass indices with log columns and a usable field
  LogInputs inputs;
};

// `row_kind` (realdata's flight windows, one per log row; realdata::AirborneRowKind: a run on the
// ground is not flight here): the gyro, accel and dynamics channels keep flight rows only (take-off,
// ground contact and the excluded tail are not in their models).
ReplayResult Replay(const logs::FlightLog& log, const vehicle::VehicleParams& vehicle, const DiagnoseOptions& options,
                    const std::vector<realdata::RowKind>& row_kind);
// Generic sensor-axis candidates (misalignment, scale_error, latency) of a vector channel whose
// prediction is h (sensor frame).
void AddAxisCandidates(const std::vector<double>& t, const std::vector<Vec3>& h, const std::string& unit,
                       ChannelData* ch);
// Gyro and accel channels on the native-rate `imu` stream (accel: thrust model driven by the `rcou`
// stream); false when the log has no imu stream (the row-based channels run instead).
bool ReplayGyroStream(const logs::FlightLog& log, const vehicle::VehicleParams& vehicle,
                      const std::vector<realdata::RowKind>& row_kind, ReplayResult* out);
bool ReplayAccelStream(const logs::FlightLog& log, const vehicle::VehicleParams& vehicle,
                       const std::vector<realdata::RowKind>& row_kind, ReplayResult* out);
// The fewest samples gap's analysis of compass channel `ch` can use (CompassMinimum::samples), from
// what that analysis fits, not from a logging rate: its largest model is the nuisance baseline plus
// the channel's largest candidate (`unknowns` parameters); it is fitted on blocked-CV training sets
// that leave out two of its time blocks, and the analysis takes at least kMinAnalysisBlocks = 4
// blocks (Analyzer, attribution.cc), so a training set holds half the samples at that floor. Each
// sample gives kEquationsPerSample = 3 equations, and the fit asks kEquationsPerUnknown = 10 per
// unknown, the in-flight model's rule (magnetics/flight_fit.h): 2·10·unknowns/3 samples.
inline constexpr int kMinAnalysisBlocks = 4;
struct CompassMinimum {
  int samples = 0;
  int unknowns = 0;
  std::string why;  // the derivation in one line, for not_diagnosed
};
CompassMinimum CompassMinSamples(const ChannelData& ch);

// One compass (index c of the vehicle's compasses) on the given timing and rows.
ChannelData ReplayCompass(const logs::FlightLog& log, const vehicle::VehicleParams& v, size_t c, const LogInputs& in,
                          const Vec3& B_N_uT, const CompassReplayOptions& options);
// The open-loop dynamics channel ("dynamics": accelerometer against the specific force predicted
// from motor commands, bus voltage, attitude and velocity); appends it or a not_diagnosed line.
double HoverRotorTimeConstant_s(const vehicle::VehicleParams& vehicle);
// The covariance of candidate c's coefficients (before c.scale) that a bias random walk of the
// channel's configured size (ChannelData::bias_walk_per_sqrt_s, each axis on its own) adds to its
// least-squares fit beside the intercept: with X̃ the demeaned regressors, A = Σ_k X̃_kᵀX̃_k and
// T_j = Σ_{k≥j} X̃_k (the walk's step between samples j−1 and j moves every later sample),
//   Cov = A⁻¹ · σ²·Σ_j (t_j − t_{j−1})·T_jᵀT_j · A⁻¹.
// The block jackknife takes blocks as independent; a walk is not (each block inherits the offset of
// the blocks before it). Empty where the channel has no walk, no intercept, or A is singular.
Eigen::MatrixXd BiasWalkCov(const ChannelData& ch, const Candidate& c);
void ReplayDynamics(const logs::FlightLog& log, const vehicle::VehicleParams& vehicle, const LogInputs& in,
                    const std::vector<realdata::RowKind>& row_kind, ReplayResult* out);

}  // namespace hexsim::gap::internal
