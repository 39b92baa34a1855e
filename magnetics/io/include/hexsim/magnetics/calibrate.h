// `hexsim calibrate` after the input is read: units, method choice (free-hand fits of
// field_calibration.h, or the turntable methods of compensator.h when the samples carry a rig's
// columns), one report with the same keys for every method, and the autopilot parameters.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "hexsim/common/status.h"
#include "hexsim/magnetics/autopilot_params.h"
#include "hexsim/magnetics/compensator.h"
#include "hexsim/magnetics/field_calibration.h"

namespace hexsim::magnetics {

struct CalibrateRequest {
  std::string method = "auto";  // FieldMethodNames() or CompensatorNames()
  std::string units = "auto";   // see DetectUnits
  double field_norm_uT = 0.0;   // local field; needed with units "counts"
  int compass_index = 0;        // 0 = mag, 1 = mag2, 2 = mag3 (autopilot parameter names)
  int px4_index = -1;           // PX4's CAL_MAGn slot when known (a ULog's device id); -1 = compass_index
  Eigen::Vector3d prior_offset = Eigen::Vector3d::Zero();  // input units (see FieldCalibrationOptions)
  FieldCalibrationOptions field;
  LearnOptions learn;
};

struct CalibrateOutcome {
  std::unique_ptr<Compensator> compensator;  // written as calib.yaml
  FieldCalibration field;                    // offset, A, K, coverage, ... (turntable methods: ground fit)
  UnitGuess units;
  std::vector<Eigen::Vector3d> raw_uT;       // the input converted to µT
  ParamList ardupilot, px4;
  nlohmann::json report;                     // hexsim.calib/1
  int exit_code = 0;                         // 1 when the acceptance gate rejects the fit
};

// `samples[i].mag_B_uT` holds the raw reading in the input's units (converted here). Errors:
// BadInput (exit 2) or Numerical (exit 3), with the reason.
Result<CalibrateOutcome> Calibrate(std::vector<MagSample> samples, const CalibrateRequest& rq);

// Whether the samples carry a turntable's columns: plane labels in 3 or more planes and 2 or more
// control amounts (auto then uses the paper's adaptive method).
bool HasTurntableColumns(const std::vector<MagSample>& samples);

}  // namespace hexsim::magnetics
