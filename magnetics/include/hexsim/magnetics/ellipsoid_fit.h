// Ellipsoid (hard + soft iron) and sphere (hard iron only) fits of compass samples, with an
// acceptance gate in the spirit of ArduPilot's CompassCalibrator.
//
// Sensor model (paper eq. 3): H = K·H̃ + β, |H̃| = r for every attitude. Correction (eq. 6):
// H̃ = K⁻¹(H − β).
//
// Scale ambiguity: (K, r) and (K/s, s·r) describe the same ellipsoid. We fix it by det(K) = 1
// (soft iron neither grows nor shrinks the volume), so r is the geometric mean of the ellipsoid's
// semi-axes — the field strength the compass would read without soft iron.
//
// Algorithm: direct algebraic fit of a general quadric with Li & Griffiths' ellipsoid-specific
// constraint (4J − I² = 1), on centred and scaled data; then Levenberg–Marquardt on the geometric
// residual e_i = ‖M(H_i − β)‖ − 1 with M = K⁻¹/r symmetric (6 parameters) and β (3 parameters).
#pragma once

#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexsim/common/status.h"
#include "hexsim/magnetics/calibration_ranges.h"

namespace hexsim::magnetics {

struct EllipsoidFitOptions {
  int min_samples = 10;
  int max_iterations = 200;
  // LM stops when the relative cost decrease or the relative parameter step falls below these.
  double function_tolerance = 1e-14;
  double parameter_tolerance = 1e-12;
  // The sample cloud is planar when (smallest / largest) principal standard deviation is below this.
  double planarity_tolerance = 1e-3;

  // Acceptance gate. Earth's field is 22–67 µT at the surface.
  // Bounds from the plausibility table (calibration_ranges.h).
  double min_radius_uT = CalibrationRange("calibration_radius").lo;
  double max_radius_uT = CalibrationRange("calibration_radius").hi;
  double min_diagonal = CalibrationRange("soft_iron_diagonal").lo;  // K(i,i) with det(K) = 1
  double max_diagonal = CalibrationRange("soft_iron_diagonal").hi;
  double max_off_diagonal = CalibrationRange("soft_iron_off_diagonal").hi;  // |K(i,j)|, i ≠ j
  double max_rms_residual_uT = 2.0;
  double max_condition_number = 1e6;  // of the column-scaled LM Jacobian
  // Coverage: fraction of `coverage_bins` direction bins (Fibonacci sphere) hit by the corrected
  // samples; or, for turntable data, the number of rotation planes the rig reports.
  int coverage_bins = 40;
  double min_coverage_fraction = 0.35;
  int planes_present = 0;           // 0 = unknown (free-hand data)
  int min_planes_for_coverage = 3;
  // Per-sample weights w_i ≥ 0 (robust reweighting): the algebraic fit and LM minimise
  // Σ w_i e_i². Empty = all 1; otherwise one per sample.
  std::vector<double> weights;

  Status IsValid() const;
};

// One criterion of the acceptance gate: its measured value, the allowed interval, and which
// bound failed ("" when it passed, "min" or "max" otherwise).
struct GateCriterion {
  std::string name;
  double value = 0.0;
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool pass = false;
  std::string failed_bound;
  std::string note;  // e.g. "passes by rig planes: 3"
};

struct FitGate {
  bool accepted = false;
  std::vector<GateCriterion> criteria;
  // The criterion named `name`, or nullptr.
  const GateCriterion* Find(const std::string& name) const;
  // "radius_uT = 120 above max 100; ..." or "" when accepted.
  std::string Failures() const;
};

struct EllipsoidFit {
  Status status;  // not OK → every number below is meaningless
  Eigen::Vector3d hard_iron_uT = Eigen::Vector3d::Zero();        // β
  Eigen::Matrix3d soft_iron = Eigen::Matrix3d::Identity();       // K, symmetric, det 1
  Eigen::Matrix3d soft_iron_inv = Eigen::Matrix3d::Identity();   // K⁻¹
  double radius_uT = 0.0;                                         // r
  double rms_residual_uT = 0.0;   // RMS of ‖K⁻¹(H − β)‖ − r
  double max_residual_uT = 0.0;
  int iterations = 0;
  bool converged = false;
  double condition_number = 0.0;
  double coverage_fraction = 0.0;
  int num_samples = 0;
  FitGate gate;

  // K⁻¹(H − β)
  Eigen::Vector3d Correct(const Eigen::Vector3d& H_uT) const { return soft_iron_inv * (H_uT - hard_iron_uT); }
};

// Hard and soft iron. BadInput for < min_samples, non-finite or planar samples; Numerical when the
// quadric is not an ellipsoid or LM fails.
EllipsoidFit FitEllipsoid(const std::vector<Eigen::Vector3d>& H_uT, const EllipsoidFitOptions& options);

// Hard iron only (K = I): ‖H − β‖ = r, linear least squares then Gauss–Newton on the geometric
// residual. The diagonal/off-diagonal criteria pass trivially.
EllipsoidFit FitSphere(const std::vector<Eigen::Vector3d>& H_uT, const EllipsoidFitOptions& options);

// Hard iron in the plane only, for samples from a flat spin about `normal`: the samples are projected
// onto the plane and a circle ‖P·h − c‖ = ρ is fitted (Kåsa, then LM on the geometric residual).
// hard_iron_uT is the circle's centre c (no component along `normal`: a spin does not determine it),
// radius_uT is ρ (the field's component in the plane), residuals are in the plane. A tilt of the
// spin axis or a wobble of a few degrees moves samples along the normal and changes nothing here.
EllipsoidFit FitCircle(const std::vector<Eigen::Vector3d>& H_uT, const Eigen::Vector3d& normal,
                       const EllipsoidFitOptions& options);

// h − (n·h)·n for a unit n: h's component in the plane normal to n.
inline Eigen::Vector3d ProjectOntoPlane(const Eigen::Vector3d& h, const Eigen::Vector3d& n) { return h - n.dot(h) * n; }

// Fraction of `bins` Fibonacci-sphere direction bins hit by the directions of `v`.
double DirectionCoverage(const std::vector<Eigen::Vector3d>& v, int bins);

}  // namespace hexsim::magnetics
