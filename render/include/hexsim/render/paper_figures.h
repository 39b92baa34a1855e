// Figures that combine several logs (overlays for `hexsim plot A.csv B.csv` and the comparison
// report), built from FlightLog columns only.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "hexsim/logs/flight_log.h"
#include "hexsim/render/figures.h"
#include "hexsim/render/plot.h"

namespace hexsim::render {

// Yaw error (deg, wrapped to ±180) per row: yaw_est_deg − yaw_true_deg where both are logged, else
// the yaw of est_q_* minus the yaw of q_*. Empty when the log has neither; NaN where a cell is missing.
std::vector<double> LogYawErrorDeg(const logs::FlightLog& log);

// The flown track from pos_N_m/pos_E_m(/pos_D_m); nullopt when the log has no such data.
std::optional<Track> LogTrack(const logs::FlightLog& log, const std::string& name);

// One curve of a quantity against time.
struct TimeCurve {
  std::string name;
  std::vector<double> t_s, values;
  std::optional<Colour> colour;
};

// Curves against time, one colour each, with a dashed zero line when `zero_line`.
Plot2D TimeOverlay(const std::string& title, const std::string& y_label, const std::vector<TimeCurve>& curves,
                   bool zero_line);

// Track overlay (top view and 3-D side by side) and yaw-error overlay of several logs into out_dir:
// overlay_tracks.png (when at least one log has pos_*), overlay_yaw_error.png (when at least one has
// a yaw error). names[i] labels logs[i]. Appends the paths written.
Status RenderLogOverlays(const std::vector<const logs::FlightLog*>& logs, const std::vector<std::string>& names,
                         const std::string& out_dir, std::vector<std::string>* written);

}  // namespace hexsim::render
