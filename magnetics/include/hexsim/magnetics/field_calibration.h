// Compass calibration from free-hand samples (any attitudes, no rig): units, orientation coverage,
// and the sphere / ellipsoid / robust fits behind `hexsim calibrate`.
//
// Convention (Magneto's): calibrated = A·(raw − b), b = offset_uT (hard iron), A symmetric positive
// definite. With the sensor model raw = K·B + b (ellipsoid_fit.h, det K = 1), A = (F/r)·K⁻¹: F is the
// local field norm when it is known (FieldCalibrationOptions::field_norm_uT), else r, the fitted
// radius, so that det A = 1 and |A·(raw − b)| ≈ r.
//
// Coverage: the eigenvalues λ1 ≤ λ2 ≤ λ3 of the sample covariance divided by s²: samples spread
// evenly over the whole sphere give ≈ 1/3 each; a flat spin about one body axis gives λ1 ≈ 0 with
// that axis as its eigenvector; little rotation gives all three small. The missing rotation is
// named from λ1's eigenvector. CalibrateField takes s = the median raw norm for a first look (too
// little rotation for any fit?), then s = a first sphere fit's radius, so that a hard iron larger
// than the field does not shrink the eigenvalues (the figures reported are the second).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexsim/common/status.h"
#include "hexsim/magnetics/ellipsoid_fit.h"

namespace hexsim::magnetics {

// The unit of the raw numbers, from the median norm or as given.
struct UnitGuess {
  std::string unit;          // "uT", "mG", "G", "nT" or "counts"
  double to_uT = 1.0;        // µT per input unit (counts: F / median norm, refined after the fit)
  double median_norm = 0.0;  // in input units
  std::string assumption;    // the printed sentence
};

// units: "auto" | "uT" | "mG" | "G" | "nT" | "counts". counts needs field_norm_uT > 0. "auto"
// takes the unit whose median norm falls in the table's raw_field_norm (calibration_ranges.h).
// BadInput when "auto" matches no unit, or counts lacks the field norm.
Result<UnitGuess> DetectUnits(const std::vector<Eigen::Vector3d>& raw, const std::string& units,
                              double field_norm_uT);

struct Coverage {
  Eigen::Vector3d eigenvalues = Eigen::Vector3d::Zero();  // ascending, dimensionless (see top)
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();     // column k: eigenvector of eigenvalues(k)
  std::string weak_axis;         // body axis nearest λ1's eigenvector: "x", "y" or "z"
  std::string missing_rotation;  // "" when coverage is full
};

Coverage ComputeCoverage(const std::vector<Eigen::Vector3d>& B, double median_norm);

// std(|B|) / mean(|B|): the relative spread of the field norm (0.01 = 1 %).
double NormSpread(const std::vector<Eigen::Vector3d>& B);

struct FieldCalibrationOptions {
  // auto | sphere | ellipsoid | robust | robust-sphere | robust-ellipsoid | none
  std::string method = "auto";
  double field_norm_uT = 0.0;  // local field (e.g. `hexsim field`); 0 = unknown
  // A flat spin does not determine the offset along its axis: the parameters carry this prior's
  // component there (the autopilot's current offset for a log, else 0), reported as undetermined.
  Eigen::Vector3d prior_offset_uT = Eigen::Vector3d::Zero();
  EllipsoidFitOptions fit;     // LM settings and acceptance gate
  int min_sphere_samples = 8;       // 4 parameters, twice over
  int min_ellipsoid_samples = 12;   // 9 parameters
  int auto_ellipsoid_samples = 50;  // auto prefers a sphere below this
  // Coverage thresholds on λ (see top): λ1 ≥ ellipsoid_eigen for an ellipsoid; λ1 below
  // sphere_eigen is a flat spin (a circle fit in its plane; the offset along the weak axis is
  // undetermined); λ2 below sphere_eigen is too little rotation for any fit.
  double ellipsoid_eigen = 0.05;
  double sphere_eigen = 0.01;
  double consistent_spread = 0.03;  // norm spread below this: "already consistent"
  // Robust reweighting (Tukey biweight, c·σ with σ = 1.4826·MAD of the residuals).
  double tukey_c = 4.685;
  int robust_iterations = 12;
  double outlier_sigmas = 5.0;  // auto switches to robust when a residual exceeds this many σ
  // Before any fit (auto and robust): samples farther than outlier_sigmas robust σ from the rest are
  // left out of the coverage and the starting fit, unless they are more than this fraction (then
  // they are no glitches and the samples are taken as they are).
  double max_screened_fraction = 0.25;
  double sigma_floor_uT = 0.0;  // robust σ never below this (the reading's LSB/√12 is always added)
};

struct FieldCalibration {
  // none | sphere | circle | ellipsoid | robust-sphere | robust-circle | robust-ellipsoid
  std::string method_used;
  std::string why;          // why this method (auto says what it looked at)
  Eigen::Vector3d offset_uT = Eigen::Vector3d::Zero();  // b
  Eigen::Matrix3d A = Eigen::Matrix3d::Identity();      // calibrated = A·(raw − b)
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();      // soft iron, det 1 (ellipsoid_fit.h)
  double radius_uT = 0.0;
  double fitness_uT = 0.0;  // RMS of |A(raw − b)| − target norm (robust: weighted)
  double norm_spread_before = 0.0;
  double norm_spread_after = 0.0;
  Coverage coverage;
  std::vector<std::string> warnings;  // incl. "model mismatch" for an offset or shape outside its range
  std::vector<size_t> downweighted;  // robust: samples whose weight ended below 0.1 (outliers)
  EllipsoidFit fit;                  // gate, iterations, ...; status OK and defaults for "none"
  // A flat spin (circle): the unit spin axis along which the offset is undetermined; zero otherwise.
  Eigen::Vector3d undetermined_axis = Eigen::Vector3d::Zero();
  bool OffsetAxisUndetermined() const { return !undetermined_axis.isZero(); }
  bool accepted = true;              // the fit's gate

  Eigen::Vector3d Correct(const Eigen::Vector3d& raw_uT) const { return A * (raw_uT - offset_uT); }
};

// Fits raw samples (µT). BadInput (exit 2): unknown method, too few samples (naming the minimum),
// coverage that cannot support the explicit method (naming the missing rotation), too little
// rotation for any fit. Numerical (exit 3): a fit that fails on usable input.
Result<FieldCalibration> CalibrateField(const std::vector<Eigen::Vector3d>& H,
                                        const FieldCalibrationOptions& o);

// auto sphere ellipsoid robust robust-sphere robust-ellipsoid none
std::vector<std::string> FieldMethodNames();

}  // namespace hexsim::magnetics
