// Attitude-aided compass calibration from a flight log (the principle of ArduPilot's offline
// fitter, MAVExplorer "magfit", and of in-flight offset learning): in flight a compass rarely sees
// every direction, so a sphere or ellipsoid through its readings alone is poorly determined; with
// the log's attitude R_NB and the World Magnetic Model the expected field is known at every sample,
// and the offset and the current-driven field become a linear least-squares problem.
//
// This is hexsim's one in-flight compass model: `calibrate --method flight` and `gap diagnose`'s
// compass channels fit it on the same samples (realdata/compass_flight.h builds them: flight windows,
// compass latency, current staleness) and report its numbers.
//
// Model, per compass sample i, in the space y = M·raw where M is the soft-iron matrix the
// autopilot already applies (kept; identity when none):
//   y_i = R_NBᵢᵀ·B_N + c + d·r_i + e_i
//   B_N   the Earth field in NED (µT), fitted with the WMM value as a Gaussian prior of σ per axis
//         (a local anomaly, a constant yaw error of the reference attitude and a uniform gain error
//         of the sensor all move it; the fit reports how far it moved);
//   c     the constant body-frame offset in y space (µT): the calibration's offset is b = M⁻¹·c,
//         so that calibrated = M·(raw − b) − d·r (ArduPilot: COMPASS_OFS = −b, COMPASS_MOT = −d);
//   r_i   the regressor of the disturbance term: the battery current I (A; form kCurrent, ArduPilot
//         COMPASS_MOTCT 2) or the collective throttle u in 0..1 (form kThrottle, COMPASS_MOTCT 1,
//         for logs without a usable current sensor);
//   d     the disturbance term (µT/A or µT per unit throttle), fitted only when the regressor varies
//         over the fit window (`min_current_span_A`, `min_throttle_span`); physical ranges:
//         plausibility rows current_hard_iron (≤ 5 µT/A) and throttle_hard_iron (≤ 60 µT).
//         Samples without a regressor value (a current sensor's first rows) are left out of the
//         fit when d is fitted; the term is never dropped for the whole log because some lack it.
// The regressor's alignment (FitFlightCompassProfiled): a logged current trails the field it causes
// by its logging staleness, which the log does not state. The fit is then given the regressor at
// several trial shifts (members) and takes the member whose fit has the smallest objective (the
// weighted SSE with the prior), on the samples every member has a value for: the shift is profiled
// by the compass's own residual, as the latency is (realdata/compass_flight.h chooses the grid).
// Intervals (the one interval method of the in-flight model): the delete-one-block jackknife over
// contiguous time blocks (`block_s`; the residual of a real log is serially correlated, so
// per-sample standard errors would be far too narrow), with Student-t quantiles at (blocks − 1)
// degrees of freedom. Each delete-one-block fit chooses its own member by its own objective, so the
// intervals hold the uncertainty of the alignment too. Samples whose residual is far from the rest
// (more than `outlier_sigma` robust standard deviations) are dropped once and counted.
#pragma once

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexsim/common/status.h"

namespace hexsim::magnetics {

struct FlightFitSample {
  Eigen::Vector3d y_uT = Eigen::Vector3d::Zero();      // M·raw
  Eigen::Matrix3d R_NB = Eigen::Matrix3d::Identity();  // attitude at the sample (body → NED)
  double current_A = 0.0;                              // battery current; NaN: unknown
  double throttle = std::nan("");                      // collective throttle 0..1; NaN: unknown
  double t_s = 0.0;                                    // for the time blocks
};

enum class FlightTermForm { kCurrent, kThrottle };

// The interval method above, as the reports name it.
constexpr const char* kFlightIntervalMethod =
    "delete-one-block jackknife, each delete-one-block fit choosing its own current shift, Student-t at blocks - 1";

constexpr int kFlightFitUnknowns = 9;     // B_N (3), c (3), d (3)
constexpr int kEquationsPerUnknown = 10;  // see FlightFitOptions::min_samples
constexpr int kEquationsPerSample = 3;
constexpr int MinFlightFitSamples() {
  return (kEquationsPerUnknown * kFlightFitUnknowns + kEquationsPerSample - 1) / kEquationsPerSample;
}
const char* FlightTermFormName(FlightTermForm form);  // "current", "throttle"
const char* FlightTermUnit(FlightTermForm form);      // "uT/A", "uT/throttle"

struct FlightFitOptions {
  Eigen::Vector3d prior_field_N_uT = Eigen::Vector3d::Zero();  // WMM at the log's place and date
  double prior_sigma_uT = 2.0;        // per axis: WMM's own error is ~0.2 µT; local anomalies and a
                                      // reference yaw error of a few degrees move the field by ~1-2 µT
  // No place and date (a log without a GPS fix): B_N is fitted freely, without the WMM prior (the
  // attitude's yaw turns separate it from c); prior_field_N_uT is then unused and rms_prior_uT is
  // the residual with no field model at all. Physical range of |B_N|: the Earth's 22-67 µT
  // (plausibility row earth_field_norm); outside it the fit is a model mismatch.
  bool field_free = false;
  double block_s = 10.0;              // cluster length for the intervals
  FlightTermForm form = FlightTermForm::kCurrent;
  double min_current_span_A = 3.0;    // the 5-95 % current span needed to fit d
  // The 5-95 % throttle span needed to fit d in throttle form: the current's 3 A over the 40-60 A a
  // small multirotor draws at full throttle is 5-8 % of full throttle.
  double min_throttle_span = 0.05;
  bool intervals = true;              // false: point estimates only (the latency scan's trial fits)
  double outlier_sigma = 6.0;         // residual norm beyond this many robust σ: dropped
  // The minimums follow from the model and the interval method, not from a logging rate. The model
  // has kFlightFitUnknowns = 9 unknowns (B_N, c, d) and each sample gives 3 equations; it asks for
  // kEquationsPerUnknown = 10 equations per unknown (the usual rule for a least-squares fit whose
  // parameters are read one by one and whose residual also sets the outlier test): 30 samples, the
  // same 30 s of a PX4 log's 1 Hz sensor_mag as 3 s at 10 Hz. The jackknife needs min_blocks blocks:
  // its Student-t at 6 − 1 = 5 degrees of freedom (2.57) widens the interval by a third over the
  // normal 1.96; fewer blocks widen it faster (t(3) = 3.18) than a short log can afford.
  int min_samples = MinFlightFitSamples();
  int min_blocks = 6;
};

struct FlightFit {
  FlightTermForm form = FlightTermForm::kCurrent;
  Eigen::Vector3d offset_y_uT = Eigen::Vector3d::Zero();   // c
  Eigen::Vector3d field_N_uT = Eigen::Vector3d::Zero();    // B_N
  Eigen::Vector3d term_uT = Eigen::Vector3d::Zero();       // d per unit regressor (zero when not fitted)
  Eigen::Vector3d offset_ci_half_uT = Eigen::Vector3d::Zero();
  Eigen::Vector3d field_ci_half_uT = Eigen::Vector3d::Zero();
  Eigen::Vector3d term_ci_half_uT = Eigen::Vector3d::Zero();
  Eigen::Matrix3d term_cov = Eigen::Matrix3d::Zero();      // the jackknife covariance of d
  double term_norm_uT = 0.0;       // |d|
  double term_norm_ci95[2] = {0.0, 0.0};  // TermNormOf
  bool term_fitted = false;
  // Test of d = 0: the largest per-axis |d_k|/se_k against the Bonferroni point t(1 − 0.05/6, G − 1)
  // (5 % overall). A joint Wald/Hotelling test was tried first: a 3×3 covariance estimated from 10-20
  // blocks is too noisy to invert (10 % false alarms at a nominal 5 % on synthetic flights).
  // Resolved when term_max_abs_t (the largest |t|) ≥ term_t_threshold.
  double term_max_abs_t = 0.0, term_t_threshold = 0.0;
  bool term_resolved = false;
  std::string term_note;  // why d was not fitted, when it was not
  double regressor_span = 0.0;    // 5-95 % span of the regressor (A or throttle)
  int without_regressor = 0;      // samples left out for want of a regressor value (d fitted)
  double rms_prior_uT = 0.0;  // residual RMS per axis with c = 0, d = 0 and the WMM field: before
  double rms_after_uT = 0.0;  // after the fit
  int samples_used = 0, outliers = 0, blocks = 0;
  std::vector<char> used;     // per input sample: in the final fit
  // The regressor's alignment (FitFlightCompassProfiled; FitFlightCompass: one member, shift 0, the
  // samples' own regressor): the chosen member's shift, the smallest and largest shift the
  // delete-one-block fits chose (their spread is in the intervals), and how many members were tried.
  double regressor_shift_s = 0.0;
  double regressor_shift_range_s[2] = {0.0, 0.0};
  int regressor_members = 1;

  // The model's prediction at a sample (d·r only where the sample has a regressor value).
  Eigen::Vector3d Predict(const FlightFitSample& s) const;
};

// The acceptance gate of an in-flight fit, one for `calibrate --method flight` and `gap diagnose`'s
// parameter files: ArduPilot's most relaxed onboard-calibration fitness (COMPASS_CAL_FIT 32 mG,
// "relaxed"), the RMS over the fitted samples of |calibrated| − |B_N|, calibrated = y − c − d·r (d
// only when `apply_term`).
constexpr double kMaxFlightFitness_uT = 3.2;
double FlightFitness_uT(const FlightFit& fit, const std::vector<FlightFitSample>& samples, bool apply_term);

// |d|, its 95 % interval and whether d is resolved from 0, from d, its covariance (block jackknife) and
// the number of blocks: one rule for calibrate's absolute term and gap's d - m (compass_terms.cc).
// - resolved: the largest per-axis |t| >= the Bonferroni point for three axes at 5 % overall (Student
//   t, blocks - 1 degrees of freedom);
// - interval: |d| -+ h, h the delta method's half-width along d (Student t 97.5 %), its low end at least
//   the largest per-axis low end max_k(|d_k| - half_k) (|d| >= |d_k|: the delta method's |d| - h reads 0
//   for a field one axis resolves where another axis is poorly resolved: a public log printed 2.5
//   [0.0, 5.8] mG/A "resolved"), clipped at 0; from 0 where d is not resolved or every axis's interval
//   holds 0 (a vector whose components may all be 0 may have no length: near 0 the norm's delta method
//   is biased away from it; simulated external compasses without a field at 1-2 Hz read 0.2-0.55 mG/A
//   with [0.02-0.09, ...]).
struct TermNorm {
  double norm = 0.0;
  std::array<double, 2> ci95 = {0.0, 0.0};
  Eigen::Vector3d axis_half = Eigen::Vector3d::Zero();  // per-axis 95 % half-widths (Student t 97.5 %)
  double max_abs_t = 0.0, t_threshold = 0.0;
  bool resolved = false;
};
TermNorm TermNormOf(const Eigen::Vector3d& term, const Eigen::Matrix3d& cov, int blocks);

// BadInput: too few samples or blocks (the message names the minimum), non-finite input.
// Numerical: a singular normal matrix (the attitude never changed).
Result<FlightFit> FitFlightCompass(const std::vector<FlightFitSample>& samples, const FlightFitOptions& options);

// The regressor at trial shifts: value[m][i] is sample i's regressor (A or throttle, as the form;
// NaN: unknown) shifted by shift_s[m] (s, ascending).
struct RegressorMembers {
  std::vector<double> shift_s;
  std::vector<std::vector<double>> value;
};
// The model with its regressor's member profiled (see the top of this file). The samples' own
// current_A/throttle is not read (the members' values are); Predict and FlightFitness_uT take
// samples that carry the chosen member's values. BadInput also for members that do not match the
// samples (a size) or a grid that is not ascending.
Result<FlightFit> FitFlightCompassProfiled(const std::vector<FlightFitSample>& samples, const RegressorMembers& members,
                                           const FlightFitOptions& options);

}  // namespace hexsim::magnetics
