// The in-flight compass model's input side (magnetics/flight_fit.h is the model): which samples,
// on which timing, with which regressor. `hexsim calibrate --method flight` and `hexsim gap
// diagnose`'s compass channels both call FitCompassInFlight, so they fit the same samples and report
// the same numbers.
//
//   windows    the log's flight windows (windows.h) when they hold enough samples, else every sample;
//              samples tilted beyond max_tilt_deg are left out (a flip or a crashed vehicle), and,
//              where the current is used, samples whose current is under min_current_per_motor_A per
//              motor (motors stopped: on the ground, whatever a window's hysteresis says).
//   staleness  the logged current trails the field it causes by its logging staleness S. The scan of
//              the current against the throttle (CurrentStaleness: StalenessScan over the flight rows)
//              reads S plus the motors' response to the throttle (the simulator's quad: ~0.18 s), so
//              it only bounds S; S itself is profiled by the compass fit's own objective over
//              CurrentShiftGrid (flight_fit.h FitFlightCompassProfiled), each jackknife replicate
//              choosing its own, and applied as the chosen member's shift. The throttle form has no
//              staleness (the commanded throttle is logged when it is commanded).
//   latency    a compass sample stamped t measured the field at t − L; L is scanned over
//              [latency_lo_s, latency_hi_s] by the model's own residual (per-block SSE, ProfileLag's
//              block bootstrap) and applied when its interval is clear of zero and plausible.
//              L is scanned with the current at the profile's choice at L = 0, then S profiled at L.
//   regressor  the battery current at t − L + S (its samples, linearly interpolated; rows outside
//              its samples carry none and are skipped by the fit); where the current is unusable
//              (the import's `current_usable` false, none logged, or its flight median under
//              min_current_per_motor_A per motor), the throttle control_u/1000 at t − L instead
//              (ArduPilot's COMPASS_MOTCT 1 form).
//   blocks     block_s = min(fit.block_s, max(min_block_s, flight span / (2·fit.min_blocks))): a short
//              log still gets 2·min_blocks jackknife blocks, each long against the current's
//              staleness (≤ 1 s) so that a block's residual is mostly its own.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexsim/common/status.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/logs/mag_input.h"
#include "hexsim/magnetics/autopilot_params.h"
#include "hexsim/magnetics/flight_fit.h"
#include "hexsim/realdata/timing.h"
#include "hexsim/realdata/windows.h"

namespace hexsim::realdata {

enum class TermChoice { kAuto, kCurrent, kThrottle };

struct CompassFlightOptions {
  magnetics::FlightFitOptions fit;   // prior_field_N_uT is set here from the log's place and date
  TermChoice term = TermChoice::kAuto;  // auto: current where usable, else throttle
  double max_tilt_deg = 60.0;        // the windows' 60° rule
  bool scan_latency = true;
  double latency_lo_s = -0.1, latency_hi_s = 0.3, latency_step_s = 0.02;
  double min_block_s = 2.0;
  // The import's data-level check: under 0.5 A per motor in flight no multirotor hovers.
  double min_current_per_motor_A = 0.5;
  int resamples = 200;
  uint64_t seed = 1;
  // CurrentStaleness(log, windows.row_kind, {resamples, seed}) of this very log, windows and options,
  // computed once by a caller that fits several compasses (gap diagnose); null: computed here.
  const LagEstimate* staleness = nullptr;
};

struct CompassFlight {
  std::vector<magnetics::FlightFitSample> samples;  // as fitted (aligned)
  std::vector<size_t> index;                        // each one's index into the MagInput samples
  magnetics::FlightFitOptions options;              // as fitted (prior, block length, form)
  magnetics::FlightFit fit;
  LagEstimate latency;
  double latency_s = 0.0;  // applied
  bool latency_applied = false;
  LagEstimate staleness;              // the scan against the throttle (it bounds the shift grid)
  std::vector<double> current_shift_grid_s;  // the shifts profiled (CurrentShiftGrid); empty: none
  double current_shift_s = 0.0;       // applied: the profile's choice
  double current_shift_range_s[2] = {0.0, 0.0};  // the delete-one-block fits' choices, smallest and largest
  bool current_usable = false;
  std::string current_note;       // why the current is unusable (empty when usable)
  // dI/du, the log's current against throttle over the flight samples (A per unit throttle), NaN
  // where the current is unusable; a throttle term's current equivalent is term / this slope.
  double current_per_throttle_A = std::nan("");
  bool flight_only = false;
  // Non-empty when the fit saw no flight: every flight window a run on the ground (motors at flight
  // output, no climb: tied down or props off), or ground samples used for want of flight ones. Its
  // disturbance term is then reported but not written as compensation: a ground run's throttle-to-
  // current relation is not the flight's (props off, a motor draws its no-load current: a 12S quad at
  // output 0.4-0.9 drew 0.66 A per motor) and its current was not checked in flight.
  std::string ground_run_note;
  std::string windows_note;
  int tilted = 0, outside = 0;
  int not_airborne = 0;  // flight-window samples at a current under min_current_per_motor_A per motor
};

// `in` is the compass's input (logs::MagInputFromFlightLog / ReadMagInput: raw readings, the
// autopilot's matrix, place and date); `log` the same flight as a FlightLog. BadInput: no attitude,
// too few samples (the model's own minimum, named); Numerical: a singular fit. Without a place and
// date the Earth field is fitted freely (FlightFitOptions::field_free) and TimingNote says so.
Result<CompassFlight> FitCompassInFlight(const logs::FlightLog& log, const logs::MagInput& in, const FlightWindows& windows,
                                         const CompassFlightOptions& options = {});

// ArduPilot's motor compensation in force for `compass` (meta compass_motct, the compass's
// motor_compensation_mG); motct −1 when the log does not say.
magnetics::MotorCompensationInLog MotorCompensationOf(const logs::FlightLog& log, const std::string& compass);

// The prepared fit as calibrate takes it (magnetics/calibrate.h), with the timing in one line.
std::string TimingNote(const CompassFlight& f);

// How stale the logged current is against the throttle (see above), over the rows of kind kFlight.
LagEstimate CurrentStaleness(const logs::FlightLog& log, const std::vector<RowKind>& kinds, const StalenessOptions& options);
// Whether a staleness scan resolved its estimate: finite, not at the grid's edge, inside its
// physical range (plausibility row current_staleness).
bool StalenessResolved(const LagEstimate& staleness);
// The shift the replay applies for a staleness estimate: its point estimate, at least 0, when it is
// resolved; else 0.
double AppliedCurrentShift_s(const LagEstimate& staleness);

// The trial shifts of the logged current against the field it causes (the in-flight model's profile
// and gap's current-driven members), ascending. Physical range: from 0 (a logged current is never
// earlier than the current that flowed) to the throttle scan's upper 95 % bound plus one update
// period (that scan's delay holds the motors' response on top of the logging staleness, so it bounds
// the staleness from above; a sample-and-hold current resolves it only to its update period), capped
// by current_staleness's range (1 s); without a resolved scan, the whole range. Steps of a quarter
// update period, within [kMinShiftStep_s, kMaxShiftStep_s]. An update period that is not positive
// and finite: the largest step.
constexpr double kMinShiftStep_s = 0.01;  // the compass latency's grid: no finer than the timing itself
// Half of it, 25 ms, is a sixth of the motors' 0.1-0.2 s response, which shapes the current's
// fastest changes: k moves little within it.
constexpr double kMaxShiftStep_s = 0.05;
std::vector<double> CurrentShiftGrid(const LagEstimate& staleness, double update_period_s);
// The median interval of a sample-and-hold channel's samples (HeldSamples::t); NaN under 2 samples.
double UpdatePeriod_s(const std::vector<double>& sample_t);

}  // namespace hexsim::realdata
