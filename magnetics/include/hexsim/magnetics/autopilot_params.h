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

// "NAME VALUE" lines (ArduPilot .parm) and QGroundControl's tab-separated
// "sysid compid NAME VALUE type" lines (type 9: float), each with a comment header.
std::string ArduPilotParmText(const ParamList& params);
std::string Px4ParamsText(const ParamList& params);

}  // namespace hexsim::magnetics
