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
#include "hexsim/magnetics/flight_fit.h"
#include "hexsim/magnetics/wmm.h"

namespace hexsim::magnetics {

// What a flight log adds to its compass samples, for the attitude-aided fit ("flight",
// flight_fit.h): the samples' q_NB are the log's attitude, and the field the autopilot corrects is
// y = body_from_raw·raw in the body frame (ArduPilot: its COMPASS_DIA/ODI matrix; PX4: its
// rotation times CAL_MAGn scales). Absent (has_attitude false) for plain dumps and turntables.
struct FlightContext {
  bool has_attitude = false;
  bool has_current = false;            // the samples' current_A is the log's battery current
  std::vector<double> t_s;             // per sample
  // Per sample: inside the log's flight windows (realdata). The fit uses flight samples when they
  // are enough: on the ground a compass sits near the pad's own iron and the yaw reference is at its
  // weakest. Empty: unknown (every sample is used).
  std::vector<char> in_flight;
  std::string windows_note;            // where the windows came from, for the report
  Eigen::Matrix3d body_from_raw = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d soft_iron_in_force = Eigen::Matrix3d::Identity();  // kept in the written parameters
  bool has_place = false;              // WMM prior for the Earth field
  GeodeticPoint where;
  double decimal_year = 0.0;
  int px4_comp_type = -1;              // PX4 CAL_MAG_COMP_TYP in the log (-1: not a PX4 log)
  Eigen::Vector3d px4_comp_G = Eigen::Vector3d::Zero();  // its CAL_MAGn_X/Y/ZCOMP
};

struct CalibrateRequest {
  std::string method = "auto";  // FieldMethodNames() or CompensatorNames()
  std::string units = "auto";   // see DetectUnits
  double field_norm_uT = 0.0;   // local field; needed with units "counts"
  int compass_index = 0;        // 0 = mag, 1 = mag2, 2 = mag3 (autopilot parameter names)
  int px4_index = -1;           // PX4's CAL_MAGn slot when known (a ULog's device id); -1 = compass_index
  Eigen::Vector3d prior_offset = Eigen::Vector3d::Zero();  // input units (see FieldCalibrationOptions)
  FieldCalibrationOptions field;
  LearnOptions learn;
  FlightContext flight;
  FlightFitOptions flight_fit;
};

struct CalibrateOutcome {
  std::unique_ptr<Compensator> compensator;  // written as calib.yaml
  FieldCalibration field;                    // offset, A, K, coverage, ... (turntable methods: ground fit)
  UnitGuess units;
  std::vector<Eigen::Vector3d> raw_uT;       // the input converted to µT
  ParamList ardupilot, px4;
  // The flight path's own: the matrix the parameters keep (else field.A) and extra parameters
  // (ArduPilot COMPASS_MOT*, PX4 CAL_MAG_COMP_TYP and CAL_MAGn_*COMP).
  bool params_keep_soft_iron = false;
  Eigen::Matrix3d params_A = Eigen::Matrix3d::Identity();
  ParamList ardupilot_extra, px4_extra;
  nlohmann::json report;                     // hexsim.calib/1
  int exit_code = 0;                         // 1 when the acceptance gate rejects the fit
};

// `samples[i].mag_B_uT` holds the raw reading in the input's units (converted here). Errors:
// BadInput (exit 2) or Numerical (exit 3), with the reason.
Result<CalibrateOutcome> Calibrate(std::vector<MagSample> samples, const CalibrateRequest& rq);

// The attitude-aided path (calibrate_flight.cc): `out` holds the converted samples and units.
Result<CalibrateOutcome> FlightPath(CalibrateOutcome out, const std::vector<MagSample>& samples, const CalibrateRequest& rq);
// Whether `auto` takes the flight path: an attitude, a place and date, no turntable columns.
bool UsesFlightPath(const std::vector<MagSample>& samples, const CalibrateRequest& rq);

// Whether the samples carry a turntable's columns: plane labels in 3 or more planes and 2 or more
// control amounts (auto then uses the paper's adaptive method).
bool HasTurntableColumns(const std::vector<MagSample>& samples);

}  // namespace hexsim::magnetics
