// The paper's turntable experiments as typed results: Table 1 with the heading residual curves
// behind it (Figs. 5–7), and the ground session's per-control ellipsoid fits and centre line
// (Figs. 3–4). Computed once, by the experiment; reports only draw them.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexsim/common/status.h"
#include "hexsim/experiments/comparison.h"
#include "hexsim/experiments/ground_calibration.h"
#include "hexsim/magnetics/compensator.h"
#include "hexsim/magnetics/ellipsoid_fit.h"
#include "hexsim/magnetics/line_fit.h"

namespace hexsim::experiments {

// Control amounts present in `samples` (ascending; amounts within 0.5 are one).
std::vector<double> DistinctControls(const std::vector<magnetics::MagSample>& samples);
// Mean battery current of the samples at `control_u` (0 when there are none).
double MeanCurrent(const std::vector<magnetics::MagSample>& samples, double control_u);

// One calibration's heading error over the level turn, per control amount, at ascending table angles.
struct HeadingCurves {
  std::string calibration;
  std::vector<double> angle_deg;                 // shared by every control amount
  std::vector<double> control_u, current_A;      // per curve
  std::vector<std::vector<double>> error_deg;    // per curve, per angle
  std::vector<double> max_abs_deg;               // per curve
};

// Table 1 rows and the curves behind them for each calibration, on `turn` (a level turn).
struct Table1 {
  HeadingErrorTable table;
  std::vector<HeadingCurves> curves;  // in calibration order
};
Result<Table1> EvaluateTable1(const std::vector<GroundCalibration>& calibrations,
                              const std::vector<double>& control_u, const std::vector<magnetics::MagSample>& turn);

// The ground session fitted per control amount: samples, ellipsoid, and the TLS line through the centres.
struct ControlFit {
  double control_u = 0.0, mean_current_A = 0.0;
  std::vector<Eigen::Vector3d> mag_B_uT;
  magnetics::EllipsoidFit fit;
};
struct GroundSessionFits {
  std::vector<ControlFit> per_control;  // ascending control amount
  bool has_line = false;                // two or more control amounts
  magnetics::SvdLineFit line;
};
Result<GroundSessionFits> FitGroundSession(const std::vector<magnetics::MagSample>& ground);

}  // namespace hexsim::experiments
