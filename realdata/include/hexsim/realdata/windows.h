// Flight windows and flight phases of a real (or simulated) FlightLog (CONTRACTS.md "Second wave").
//
// Each log row gets one kind:
//   flight    armed (the `armed` column, or throttle when the log has no armed state), throttle above
//             the armed idle level, attitude sane;
//   ground    disarmed, or armed at idle throttle, before any flip or crash: kept as evidence of its
//             own (ground-vs-hover comparisons, compassmot's principle), never mixed into flight;
//   excluded  a flip or crash and everything after it: sustained |roll| or |pitch| above
//             max_tilt_deg for sustained_s, or an impact (|specific force| above impact_mps2) after
//             which the flight ends within crash_settle_s (log end, disarm, idle throttle); the cut
//             starts where the attitude last was sane (tilt below sane_tilt_deg), lead_s earlier.
// Segments shorter than min_segment_s are merged into their neighbours (hysteresis), except that an
// excluded tail is never shortened.
#pragma once

#include <string>
#include <vector>

#include "hexsim/logs/flight_log.h"

namespace hexsim::realdata {

enum class RowKind { kExcluded = 0, kGround = 1, kFlight = 2 };

struct WindowOptions {
  double max_tilt_deg = 60.0;   // a multirotor in controlled flight stays well below this
  double sustained_s = 0.5;     // longer than any gust or aggressive-manoeuvre excursion
  double sane_tilt_deg = 30.0;  // the cut goes back to where the tilt last was below this
  double lead_s = 0.5;          // and this much earlier (the manoeuvre starting)
  double impact_mps2 = 5.0 * 9.80665;  // |specific force| of a crash, above any landing
  double crash_settle_s = 3.0;  // a crash ends the flight within this (ArduPilot's crash check disarms after 2 s)
  double idle_margin = 0.05;    // flight: throttle (0..1) above the armed idle level by this
  double min_segment_s = 2.0;   // shorter segments merge into their neighbours
};

struct Window {
  double start_s = 0.0, end_s = 0.0;
  std::string kind;  // flight | ground | excluded
  std::string why;
  // A flight window (motors at flight output) whose logged height never climbs (logs::
  // kMinFlightClimb_m): a run on the ground, tied down or props off. Its rows stay flight for the
  // compasses (the current's field at the compass is the same on the ground: compassmot's
  // principle) and are not airborne for the inertial and dynamics replays (AirborneRowKind).
  bool on_ground = false;
};

struct FlightWindows {
  std::vector<Window> windows;
  std::vector<RowKind> row_kind;  // per log row
  double cut_at_s;                // start of the excluded tail, NaN when nothing was cut
  std::string cut_why;
  std::string armed_source;       // where the armed state came from
  double idle_throttle = 0.0;     // armed idle level (0..1), NaN when unknown
  bool overridden = false;        // --from/--to given
  FlightWindows();
  // Rows of the given kind.
  size_t Count(RowKind kind) const;
};

// Windows from the log's armed state, throttle and attitude.
FlightWindows FindFlightWindows(const logs::FlightLog& log, const WindowOptions& options = {});
// The row kinds with the rows of on-ground flight windows as ground: what the inertial and dynamics
// replays may take as airborne.
std::vector<RowKind> AirborneRowKind(const logs::FlightLog& log, const FlightWindows& fw);
// The user's window: rows in [from_s, to_s] are flight, the rest excluded (`--from/--to`).
FlightWindows WindowsFromRange(const logs::FlightLog& log, double from_s, double to_s);

// Merges runs shorter than min_segment_s into the longer neighbour (labels per sample, t ascending).
// Labels listed in `fixed` are never changed nor grown into.
std::vector<std::string> MergeShortSegments(const std::vector<double>& t, std::vector<std::string> labels,
                                            double min_segment_s, const std::vector<std::string>& fixed = {});

// Flight phases per row: ground, takeoff, hover, climb, cruise, descent, landing, excluded (and
// unknown without height). Inside flight windows the phase follows height above the last ground
// level and vertical/horizontal speed; takeoff is near the ground after a ground segment, landing
// near the ground before one. Segments are merged to at least min_segment_s.
std::vector<std::string> PhaseLabels(const logs::FlightLog& log, const FlightWindows& windows,
                                     double min_segment_s = 2.0);

}  // namespace hexsim::realdata
