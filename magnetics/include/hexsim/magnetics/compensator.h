// Compass compensators, one interface, selectable by name, learnt from turntable samples.
//
//   none              identity.
//   traditional       ellipsoid fit on the control-0 samples only: K⁻¹(H − β).
//   adaptive          the paper: one ellipsoid per control amount → centres → space line (TLS,
//                     direction-vector form) → hard iron moved along the line by the control
//                     amount (monotone PCHIP in control_u by default); soft iron K from the
//                     control-0 fit: K⁻¹(H − β(u)).
//   adaptive-current  as adaptive, but the position along the line is linear in the measured
//                     battery current: K⁻¹(H − β(I)).
//   compassmot        ArduPilot style: ground ellipsoid (K, β) plus a field-per-ampere vector c
//                     in the *corrected* frame, learnt from matched pairs (same plane and table
//                     angle, control > 0 vs control 0): K⁻¹(H(I) − H(0)) = c·(I − I0).
//                     Correction K⁻¹(H − β) − c·(I − I0) (AP applies motor offsets after the
//                     soft-iron matrix).
//   px4-ls            PX4 style: per-axis least squares of the *raw* field on current over all
//                     samples with a free offset per (plane, angle) pose: H = o_pose + c·I.
//                     Correction K⁻¹(H − β − c·(I − I0)) (PX4 removes power compensation from
//                     the raw reading before offsets and scale).
// I0 is the mean current of the control-0 samples (the avionics' draw).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "hexsim/common/status.h"
#include "hexsim/magnetics/ellipsoid_fit.h"
#include "hexsim/magnetics/line_fit.h"

namespace hexsim::magnetics {

struct CompensatorInput {
  double control_u = 0.0;  // collective 0..1000
  double current_A = 0.0;  // measured battery current
};

class Compensator {
 public:
  virtual ~Compensator() = default;
  virtual std::string name() const = 0;
  // Raw body-frame reading → corrected body-frame field (µT).
  virtual Eigen::Vector3d Correct(const Eigen::Vector3d& raw_B_uT, const CompensatorInput& in) const = 0;
};

// What a user records on the turntable or in a throttle ramp (sensor data only — never simulator
// truth, except earth_B_uT which is used ONLY by heading evaluation).
struct MagSample {
  std::string plane;  // "xy", "yz", "xz" or "" (free-hand)
  double control_u = 0.0;
  double current_A = 0.0;
  double angle_deg = 0.0;
  Eigen::Vector3d mag_B_uT = Eigen::Vector3d::Zero();
  // Attitude known from the rig (turntable angle); heading evaluation only, not hard/soft iron.
  Eigen::Quaterniond q_NB = Eigen::Quaterniond::Identity();
  // True Earth field in body frame (samples.csv earth_*): heading evaluation only.
  Eigen::Vector3d earth_B_uT = Eigen::Vector3d::Zero();
};

enum class LineForm { kDirectionVector, kPaper };

struct LearnOptions {
  EllipsoidFitOptions ellipsoid;       // also the gate for every ellipsoid fitted
  LineFitOptions line;
  LineForm line_form = LineForm::kDirectionVector;  // kPaper: eq. 13–16, fails when singular
  AlongKind along_control = AlongKind::kMonotone;  // adaptive: position vs control amount
  int min_samples_per_fit = 10;        // per control amount
  // Distinct non-empty `plane` labels per fit (free-hand data: ignored). Two turntable circles do
  // not determine an ellipsoid (a pencil of quadrics passes through them), so three by default.
  int min_planes = 3;
  int min_control_amounts = 2;         // adaptive, adaptive-current, compassmot, px4-ls
  double control_zero_max_u = 0.5;     // control_u ≤ this counts as "control 0"
  double angle_match_deg = 0.5;        // compassmot: pairs with the same plane and angle
  double min_current_span_A = 1.0;     // current-indexed methods need this much current variation
  Status IsValid() const;
};

// What LearnCompensator fitted, for its report (magnetics_io's LearnReportToJson writes hexsim.calib/1).
struct LearnedFit {
  double control_u = 0.0;  // the group's control amount
  double mean_current_A = 0.0;
  int planes = 0;          // distinct rig planes in the group
  EllipsoidFit fit;
};
// The paper's line form x = a z + b, y = c z + d (LineForm::kPaper) beside the direction-vector fit.
struct PaperLineSummary {
  double a = 0.0, b_uT = 0.0, c = 0.0, d_uT = 0.0;
  int iterations = 0;
  double rms_residual_uT = 0.0;
  double angle_to_svd_deg = 0.0;  // between the paper line and the direction-vector line
};
// Each method's own figures; the absent ones are not reported.
struct LearnDiagnostics {
  std::optional<double> line_svd_rms_residual_uT;  // adaptive methods: centres about the line
  std::optional<PaperLineSummary> line_paper;
  std::optional<double> along_rms_residual_uT;     // position along the line vs its model
  std::string along_index;                         // "control_u" | "current_A"
  std::string along_model;                         // "linear" | "monotone"
  std::optional<double> pair_rms_residual_uT;      // compassmot
  std::optional<double> pose_rms_residual_uT;      // px4-ls
  std::optional<int> samples_used_for_c;           // compassmot, px4-ls
};
struct LearnReport {
  std::string method;
  std::vector<LearnedFit> fits;  // fits[0]: the ground (lowest-control) fit; none for "none"
  LearnDiagnostics diagnostics;
  size_t num_samples = 0;
  bool accepted() const;         // every fit passed its gate
};

// Learns `method` (one of CompensatorNames()). BadInput with a clear reason when the samples
// cannot support the method (one plane, too few, NaN, one control amount for adaptive, ...);
// Numerical for a singular fit. `report` (may be null) receives what was fitted. A fit rejected by
// its gate still returns the compensator, with report->accepted() false.
Result<std::unique_ptr<Compensator>> LearnCompensator(const std::string& method, const std::vector<MagSample>& samples,
                                                      const LearnOptions& options, LearnReport* report);

// none, traditional, adaptive, adaptive-current, compassmot, px4-ls
std::vector<std::string> CompensatorNames();

// The identity compensator ("none").
std::unique_ptr<Compensator> MakeNoneCompensator();

}  // namespace hexsim::magnetics
