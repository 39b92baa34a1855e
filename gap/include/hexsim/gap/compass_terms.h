// A compass channel's absolute terms from hexsim's one in-flight compass model
// (magnetics/flight_fit.h, samples from realdata/compass_flight.h): the same fit `hexsim calibrate
// --method flight` reports, on the same windows and timing, so the two commands print the same
// numbers. Beside them, the gap: the absolute current term minus the field per ampere the vehicle
// file's wiring and motors put at this compass (magnetics current_field), the part the simulator
// does not model.
//
// The absolute terms are fitted on every flight block (as calibrate); the candidates' shares of a
// gap channel are measured on held-out blocks (the report says both).
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexsim/magnetics/autopilot_params.h"
#include "hexsim/magnetics/flight_fit.h"

namespace hexsim::gap {

// Field units: hexsim computes in µT; reports and autopilots (COMPASS_OFS, COMPASS_MOT) use mG.
// 1 G = 100 µT = 1000 mG, so 1 µT = 10 mG.
inline constexpr double kMilliGaussPerMicroTesla = 10.0;

struct CompassTerms {
  std::string channel;          // mag, mag2, ...
  std::string form;             // "current" (uT/A) or "throttle" (uT per unit throttle)
  std::string current_note;     // why the current was not used (empty when it was)
  // Offset b in the raw reading (calibrated = M·(raw − b)), uT, and its 95 % half-widths.
  Eigen::Vector3d offset_uT = Eigen::Vector3d::Zero(), offset_ci_half_uT = Eigen::Vector3d::Zero();
  bool offset_plausible = true;  // plausibility row compass_offset
  // calibrate's acceptance gate (flight_fit.h kMaxFlightFitness_uT, the offset plausible): a compass it
  // rejects gets no parameters in gap's calib.parm/.params either.
  double fitness_uT = 0.0;
  bool gate_accepted = true;
  Eigen::Vector3d field_N_uT = Eigen::Vector3d::Zero(), field_ci_half_uT = Eigen::Vector3d::Zero();
  Eigen::Vector3d wmm_field_N_uT = Eigen::Vector3d::Zero();
  // The disturbance term d (body frame, per unit of the form's regressor) and |d| with its interval.
  bool term_fitted = false, term_resolved = false, term_plausible = true;
  // realdata::CompassFlight::ground_run_note: the fit saw no flight, so its term is not written.
  std::string ground_run_note;
  std::string term_note;
  Eigen::Vector3d term_uT = Eigen::Vector3d::Zero(), term_ci_half_uT = Eigen::Vector3d::Zero();
  double term_norm_uT = 0.0, term_norm_ci95_uT[2] = {0.0, 0.0};
  // Throttle form where the current is usable: |d| / (dI/du), the log's own current-vs-throttle slope.
  double current_equivalent_uT_per_A = std::nan(""), current_equivalent_ci95_uT_per_A[2] = {0.0, 0.0};
  // Current form: the vehicle file's modelled field per ampere of battery current at this compass
  // (body frame, motors sharing the current equally) and the gap d − modelled with its interval.
  bool modelled_available = false;
  Eigen::Vector3d modelled_uT_per_A = Eigen::Vector3d::Zero();
  Eigen::Vector3d gap_uT_per_A = Eigen::Vector3d::Zero();
  double gap_norm_uT_per_A = 0.0, gap_norm_ci95_uT_per_A[2] = {0.0, 0.0};
  // Timing as applied, the fit's size, and how the interval was computed.
  // current_shift_s: the current's shift the model chose by its own fit (realdata/compass_flight.h);
  // current_shift_range_s: the smallest and largest shift its delete-one-block fits chose.
  double latency_s = 0.0, current_shift_s = 0.0, current_shift_range_s[2] = {0.0, 0.0};
  bool latency_applied = false;
  std::string timing_note, windows_note;
  bool flight_only = false;  // fitted on flight windows only (false: ground samples were needed too)
  int samples = 0, blocks = 0, without_regressor = 0;
  double block_s = 0.0, rms_before_uT = 0.0, rms_after_uT = 0.0;
  std::string interval_method = magnetics::kFlightIntervalMethod;
  std::string held_out = "absolute terms fitted on every flight block (as hexsim calibrate); candidates' shares on "
                         "held-out blocks";
  // Parameters to paste (autopilot_params.h): offsets where plausible, the compensation where resolved
  // and plausible, the log's COMPASS_MOTCT / COMPASS_MOT* handled as `motor.action` says.
  magnetics::ParamList ardupilot, px4;
  magnetics::MotorParams motor;
};

// calib.parm (ArduPilot) and calib.params (PX4) texts for these compasses, with the same writer as
// `hexsim calibrate` (autopilot_params.h); both empty when no compass has a parameter to paste.
struct ParamFiles {
  std::string parm, params;
};
ParamFiles CompassParamFiles(const std::vector<CompassTerms>& terms);

}  // namespace hexsim::gap
