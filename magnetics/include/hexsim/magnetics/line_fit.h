// Space-line fits of the ellipsoid centres (hard iron vs control amount or current), and the 1-D
// model of the position along the line.
//
// Two line forms:
//  (a) the paper's (eq. 13–16): x = a·z + b, y = c·z + d, fitted by its iterative total least
//      squares. Singular when z does not vary (centres moving in the X-Y plane): use it only to
//      reproduce the paper, checked against (b).
//  (b) direction-vector form: centroid + principal direction (SVD, orthogonal regression); works
//      for any direction. This is what the compensators use.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexsim/common/status.h"

namespace hexsim::magnetics {

// p(s) = point_uT + s·direction, ‖direction‖ = 1, s in µT.
struct SpaceLine {
  Eigen::Vector3d point_uT = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();
  Eigen::Vector3d At(double s_uT) const { return point_uT + s_uT * direction; }
  // Signed position of the foot of the perpendicular from p.
  double PositionOf(const Eigen::Vector3d& p_uT) const { return direction.dot(p_uT - point_uT); }
  double DistanceTo(const Eigen::Vector3d& p_uT) const;
};

struct LineFitOptions {
  int max_iterations = 500;
  // Stop when ‖Δξ‖ < tolerance·(1 + ‖ξ‖). The iteration converges linearly (ratio ≈ 0.5 for
  // noisy centres) to a round-off floor near 1e-11, so do not ask for less than ~1e-10.
  double tolerance = 1e-9;
  double singular_tolerance = 1e-6;  // (a) singular when spread(z)/spread(all) is below this
  Status IsValid() const;
};

// (a) The paper's form. The iteration (eq. 15–16) runs on centroid-centred coordinates with
// ξ = [a c]: the paper's update also perturbs B's exact constant columns, which lets the
// intercepts run away on noisy data; the TLS line passes through the centroid, so b and d are
// restored from it.
struct PaperLineFit {
  Status status;  // Numerical "singular ..." when z does not vary; "did not converge" otherwise
  double a = 0.0, b_uT = 0.0, c = 0.0, d_uT = 0.0;  // x = a z + b, y = c z + d
  int iterations = 0;
  bool converged = false;
  double rms_residual_uT = 0.0;  // orthogonal distance of the points to the line
  SpaceLine line;                // the same line in direction-vector form
};
PaperLineFit FitLinePaperTls(const std::vector<Eigen::Vector3d>& points_uT, const LineFitOptions& options);

// (b) Orthogonal regression.
struct SvdLineFit {
  Status status;
  SpaceLine line;                // point = centroid; direction = principal axis, sign: largest |component| > 0
  double rms_residual_uT = 0.0;  // orthogonal distance
  Eigen::Vector3d singular_values = Eigen::Vector3d::Zero();
};
SvdLineFit FitLineSvd(const std::vector<Eigen::Vector3d>& points_uT);

// Position along the line as a function of a scalar x (control amount or current).
enum class AlongKind { kLinear, kMonotone };
struct AlongModel {
  AlongKind kind = AlongKind::kLinear;
  // kLinear: s = s0 + k·x.
  double s0_uT = 0.0;
  double k_uT_per_x = 0.0;
  // kMonotone: PCHIP (Fritsch–Carlson) through the knots, linear extrapolation with the end slopes.
  std::vector<double> knots_x, knots_s_uT, slopes;
  double Eval(double x) const;
};
struct AlongFit {
  Status status;
  AlongModel model;
  double rms_residual_uT = 0.0;
};
// Least squares s = s0 + k·x. Needs two distinct x.
AlongFit FitLinearAlong(const std::vector<double>& x, const std::vector<double>& s_uT);
// Averages repeated x, makes s monotone in x (pool-adjacent-violators in the direction of the
// overall trend), then PCHIP. Needs two distinct x.
AlongFit FitMonotoneAlong(const std::vector<double>& x, const std::vector<double>& s_uT);

// Hard-iron offset for a given x: line.At(along.Eval(x)).
struct HardIronLine {
  SpaceLine line;
  AlongModel along;
  Eigen::Vector3d At(double x) const { return line.At(along.Eval(x)); }
};

}  // namespace hexsim::magnetics
