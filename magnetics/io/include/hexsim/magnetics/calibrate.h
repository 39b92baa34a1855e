// `hexsim calibrate` after the input is read: units, method choice (free-hand fits of
// field_calibration.h, or the turntable methods of compensator.h when the samples carry a rig's
// columns), one report with the same keys for every method, and the autopilot parameters.
#pragma once

#include <cmath>
#include <memory>
#include <optional>
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

// The in-flight compass model's samples and fit (flight_fit.h), prepared by the caller with the
// log's windows and timing (realdata::FitCompassInFlight), so that `calibrate` and `gap diagnose`
// fit the same samples.
struct PreparedFlightFit {
  std::vector<FlightFitSample> samples;
  std::vector<size_t> index;  // each one's index into the calibrate samples
  FlightFitOptions options;   // as fitted (WMM prior, block length, form)
  FlightFit fit;
  std::string windows_note;
  bool flight_only = true;
  int tilted = 0, outside = 0;
  std::string timing_note;    // compass latency and current staleness as applied
  // The current's shift as applied (chosen by the fit over the caller's grid, or fixed), and the
  // smallest and largest shift the delete-one-block fits chose.
  double current_shift_s = 0.0, current_shift_range_s[2] = {0.0, 0.0};
  std::string current_note;   // why the current is unusable (empty when usable)
  double current_per_throttle_A = std::nan("");
  // realdata::CompassFlight::ground_run_note: the fit saw no flight, its term is not applied.
  std::string ground_run_note;
};

// What a flight log adds to its compass samples, for the attitude-aided fit ("flight").
// Absent (has_attitude false) for plain dumps and turntables.
struct FlightContext {
  bool has_attitude = false;
  bool has_place = false;
  std::optional<PreparedFlightFit> prepared;  // required by the flight path
  Eigen::Matrix3d body_from_raw = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d soft_iron_in_force = Eigen::Matrix3d::Identity();  // kept in the written parameters
  MotorCompensationInLog motor_compensation;  // ArduPilot COMPASS_MOTCT / COMPASS_MOT* in force
  int px4_comp_type = -1;              // PX4 CAL_MAG_COMP_TYP in the log (-1: not a PX4 log)
  Eigen::Vector3d px4_comp_G = Eigen::Vector3d::Zero();  // its CAL_MAGn_X/Y/ZCOMP
};

// The flight path's typed result (printed by the command; its report keys are derived from it).
struct FlightOutcome {
  PreparedFlightFit in;
  bool term_applied = false;   // resolved and plausible: written as the autopilots' compensation
  bool term_plausible = true;
  double field_norm_vs_wmm = 0.0;
  std::string motor_params_note;  // what was done with COMPASS_MOTCT / COMPASS_MOT*
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
  std::optional<FlightOutcome> flight;       // the flight path's
  std::vector<std::string> param_comments;   // comment lines for calib.parm / calib.params
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
