// Attitude-aided compass calibration from a flight log (the principle of ArduPilot's offline
// fitter, MAVExplorer "magfit", and of in-flight offset learning): in flight a compass rarely sees
// every direction, so a sphere or ellipsoid through its readings alone is poorly determined; with
// the log's attitude R_NB and the World Magnetic Model the expected field is known at every sample,
// and the offset and the current-driven field become a linear least-squares problem.
//
// Model, per compass sample i, in the space y = M·raw where M is the soft-iron matrix the
// autopilot already applies (kept; identity when none):
//   y_i = R_NBᵢᵀ·B_N + c + d·I_i + e_i
//   B_N   the Earth field in NED (µT), fitted with the WMM value as a Gaussian prior of σ per axis
//         (a local anomaly, a constant yaw error of the reference attitude and a uniform gain error
//         of the sensor all move it; the fit reports how far it moved);
//   c     the constant body-frame offset in y space (µT): the calibration's offset is b = M⁻¹·c,
//         so that calibrated = M·(raw − b) − d·I (ArduPilot: COMPASS_OFS = −b, COMPASS_MOT = −d);
//   d     the current-driven field (µT/A), fitted only when the current varies over the fit window
//         (`min_current_span_A`); physical range: plausibility row current_hard_iron (≤ 5 µT/A).
// Intervals are cluster-robust over time blocks (`block_s`; the residual of a real log is
// serially correlated, so per-sample standard errors would be far too narrow), with Student-t
// quantiles at (blocks − 1) degrees of freedom. Samples whose residual is far from the rest (more
// than `outlier_sigma` robust standard deviations) are dropped once and counted.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexsim/common/status.h"

namespace hexsim::magnetics {

struct FlightFitSample {
  Eigen::Vector3d y_uT = Eigen::Vector3d::Zero();      // M·raw
  Eigen::Matrix3d R_NB = Eigen::Matrix3d::Identity();  // attitude at the sample (body → NED)
  double current_A = 0.0;                              // NaN: unknown (the sample is kept, d unused)
  double t_s = 0.0;                                    // for the time blocks
};

struct FlightFitOptions {
  Eigen::Vector3d prior_field_N_uT = Eigen::Vector3d::Zero();  // WMM at the log's place and date
  double prior_sigma_uT = 2.0;        // per axis: WMM's own error is ~0.2 µT; local anomalies and a
                                      // reference yaw error of a few degrees move the field by ~1-2 µT
  double block_s = 10.0;              // cluster length for the intervals
  double min_current_span_A = 3.0;    // the 5-95 % current span needed to fit d
  double outlier_sigma = 6.0;         // residual norm beyond this many robust σ: dropped
  int min_samples = 60;
  int min_blocks = 6;
};

struct FlightFit {
  Eigen::Vector3d offset_y_uT = Eigen::Vector3d::Zero();   // c
  Eigen::Vector3d field_N_uT = Eigen::Vector3d::Zero();    // B_N
  Eigen::Vector3d current_uT_per_A = Eigen::Vector3d::Zero();  // d (zero when not fitted)
  Eigen::Vector3d offset_ci_half_uT = Eigen::Vector3d::Zero();
  Eigen::Vector3d field_ci_half_uT = Eigen::Vector3d::Zero();
  Eigen::Vector3d current_ci_half_uT_per_A = Eigen::Vector3d::Zero();
  double current_norm_uT_per_A = 0.0;       // |d|
  double current_norm_ci95[2] = {0.0, 0.0};  // delta method, clipped at 0
  bool current_fitted = false;
  // Test of d = 0: the largest per-axis |d_k|/se_k against the Bonferroni point t(1 − 0.05/6, G − 1)
  // (5 % overall). A joint Wald/Hotelling test was tried first: a 3×3 covariance estimated from 10-20
  // blocks is too noisy to invert (10 % false alarms at a nominal 5 % on synthetic flights).
  // Resolved when current_max_abs_t (the largest |t|) ≥ current_t_threshold.
  double current_max_abs_t = 0.0, current_t_threshold = 0.0;
  bool current_resolved = false;
  std::string current_note;  // why d was not fitted, when it was not
  double current_span_A = 0.0;
  double rms_prior_uT = 0.0;  // residual RMS per axis with c = 0, d = 0 and the WMM field: before
  double rms_after_uT = 0.0;  // after the fit
  int samples_used = 0, outliers = 0, blocks = 0;
};

// BadInput: too few samples or blocks (the message names the minimum), non-finite input.
// Numerical: a singular normal matrix (the attitude never changed).
Result<FlightFit> FitFlightCompass(const std::vector<FlightFitSample>& samples, const FlightFitOptions& options);

}  // namespace hexsim::magnetics
