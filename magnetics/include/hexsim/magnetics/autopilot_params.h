// A compass calibration as autopilot parameters, and the autopilots' own corrections (so that a
// written parameter set can be checked by applying it the way the firmware does).
//
// ArduPilot (AP_Compass::correct_field): corrected = M·(raw + OFS), raw and OFS in milligauss,
//   M = [[DIA_X, ODI_X, ODI_Y], [ODI_X, DIA_Y, ODI_Z], [ODI_Y, ODI_Z, DIA_Z]] (unitless).
//   From calibrated = A·(raw − b): OFS = −b (mG), M = A / ∛det A (ArduPilot keeps the field's size
//   separate, in COMPASS_SCALE, which is not written).
//   Names: compass 0 COMPASS_OFS_X, COMPASS_DIA_X, COMPASS_ODI_X; compass n > 0 COMPASS_OFS{n+1}_X ...
// PX4 (sensors/data_validator Magnetometer calibration): corrected = S·(raw − OFF), raw and OFF in
//   gauss, S = [[XSCALE, XODIAG, YODIAG], [XODIAG, YSCALE, ZODIAG], [YODIAG, ZODIAG, ZSCALE]].
//   OFF = b (G), S = A / ∛det A. Names CAL_MAG{n}_XOFF ... for instance n.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace hexsim::magnetics {

using ParamList = std::vector<std::pair<std::string, double>>;  // in writing order

// compass_index: 0 for `mag`, 1 for `mag2`, 2 for `mag3`.
ParamList ArduPilotCompassParams(const Eigen::Vector3d& offset_uT, const Eigen::Matrix3d& A, int compass_index);
ParamList Px4CompassParams(const Eigen::Vector3d& offset_uT, const Eigen::Matrix3d& A, int compass_index);

// ArduPilot's correction with the parameters of `params` for `compass_index` (missing DIA → 1,
// ODI/OFS → 0): M·(raw + OFS), in mG.
Eigen::Vector3d ApplyArduPilotCompass(const ParamList& params, int compass_index, const Eigen::Vector3d& raw_mG);
// PX4's: S·(raw − OFF), in gauss.
Eigen::Vector3d ApplyPx4Compass(const ParamList& params, int compass_index, const Eigen::Vector3d& raw_G);

// ArduPilot's motor compensation as the log had it: COMPASS_MOTCT (0 none, 1 throttle, 2 current;
// -1 unknown) and this compass's COMPASS_MOT*_X/Y/Z (mG per A or per unit throttle).
struct MotorCompensationInLog {
  int motct = -1;
  Eigen::Vector3d mot = Eigen::Vector3d::Zero();
};

// The in-flight model's disturbance term as ArduPilot and PX4 compensation parameters, with what was
// done to the log's own (`action`: "written", "replaced", "kept", "zeroed", "none"; `comment` says it
// in a line for the parameter files). form_throttle: d is per unit throttle (COMPASS_MOTCT 1), else per A
// (COMPASS_MOTCT 2). usable: resolved from zero and inside its physical range. d_ci_half_uT: per axis.
// no_flight: why the fit saw no flight (realdata::CompassFlight::ground_run_note), empty when it did:
// then nothing is written or zeroed, the log's own compensation is kept, and the comment says why.
struct MotorParams {
  ParamList ardupilot, px4;
  std::string action, comment;
};
MotorParams CompensationParams(int compass_index, int px4_index, bool fitted, bool usable, bool form_throttle,
                               const Eigen::Vector3d& d_uT, const Eigen::Vector3d& d_ci_half_uT,
                               const Eigen::Matrix3d& body_from_raw_inv, const MotorCompensationInLog& log,
                               int px4_comp_type, const Eigen::Vector3d& px4_comp_G, const std::string& no_flight = {});

// "NAME VALUE" lines (ArduPilot .parm) and QGroundControl's tab-separated
// "sysid compid NAME VALUE type" lines (type 9: float), each with a comment header.
// `source` names the command in the header; `comments` are added as "# ..." lines after it.
std::string ArduPilotParmText(const ParamList& params, const std::string& source = "hexsim calibrate",
                              const std::vector<std::string>& comments = {});
std::string Px4ParamsText(const ParamList& params, const std::string& source = "hexsim calibrate",
                          const std::vector<std::string>& comments = {});

}  // namespace hexsim::magnetics
