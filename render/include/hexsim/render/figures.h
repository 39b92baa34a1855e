// Ready-made figures: the standard set for any FlightLog (`hexsim plot`), and helpers for the paper's
// figures and the reports. They take plain vectors, so render/ depends on no model library.
#pragma once

#include <string>

#include <nlohmann/json.hpp>
#include <vector>

#include "hexsim/common/status.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/render/image.h"
#include "hexsim/render/plot.h"

namespace hexsim::render {

inline constexpr int kFigureWidth_px = 1100;
inline constexpr int kFigureHeight_px = 680;

// Writes the standard figures of a log into `out_dir` (created if missing), each only when its
// columns exist and hold data: track_top.png (N/E: truth, est_pos, GPS), altitude.png, attitude.png
// (roll/pitch/yaw from q, est_q dashed), yaw_error.png (yaw_est − yaw_true), compass_<prefix>.png per
// compass (x/y/z and |B|), power.png (current, voltage), motors.png (motor_i_u, control_u),
// track_3d.png. Flight phases (runs of constant `mode`) are shaded. Appends the paths written.
Status RenderStandardFigures(const logs::FlightLog& log, const std::string& out_dir,
                             std::vector<std::string>* written);

// The name of flight mode number `mode` in a log: the log meta's `mode_names` (a simulated log: the
// sequencer's idle/takeoff/waypoint/...), else by its format the ArduCopter mode numbers
// (ardupilot-dataflash) or PX4's vehicle_status.nav_state (px4-ulog); "mode N" when unknown.
std::string FlightModeLabel(const nlohmann::json& meta, double mode);

// A track in NED metres. Plots show East right, North up, altitude = −down.
struct Track {
  std::string name;
  std::vector<double> north_m, east_m, down_m;  // down_m may be empty (then 0)
  std::optional<Colour> colour;
};
// Planned path (waypoints joined, dashed, with markers) and the flown tracks.
Plot2D TracksTopView(const Track& planned, const std::vector<Track>& flown);
Plot3D Tracks3D(const Track& planned, const std::vector<Track>& flown);
// Top view and 3-D view side by side.
Result<Image> RenderTracks(const Track& planned, const std::vector<Track>& flown, int width_px = 1400,
                           int height_px = 640);

// One curve per method against a common abscissa.
struct NamedCurve {
  std::string name;
  std::vector<double> values;
};
// Heading error (deg) vs table angle (deg), one curve per method, zero line, x ticks at 0..360.
Plot2D HeadingResidualPlot(const std::vector<double>& angle_deg, const std::vector<NamedCurve>& error_deg);
Result<Image> RenderHeadingResidual(const std::vector<double>& angle_deg, const std::vector<NamedCurve>& error_deg,
                                    int width_px = kFigureWidth_px, int height_px = kFigureHeight_px);

// Compass samples at one control amount (µT, body axes).
struct SampleCloud {
  std::string label;
  std::vector<Point3> points_uT;
  std::optional<Colour> colour;  // unset: palette colour of its index
};
// The paper's Fig. 3: a 3-D view of every cloud with its fitted ellipsoid (fits[i] goes with
// clouds[i]; fewer fits than clouds is fine) and the XY, YZ and XZ projections with the fitted
// ellipsoids' outlines and centres.
Result<Image> RenderEllipsoidClouds(const std::vector<SampleCloud>& clouds, const std::vector<Ellipsoid3D>& fits,
                                    int width_px = 1200, int height_px = 1000);

// The ellipsoid centres (one per control amount, labelled) and the fitted line
// {point + s·direction}, drawn across the centres' span: 3-D view and the three projections.
Result<Image> RenderCentreLine(const std::vector<Point3>& centres_uT, const std::vector<std::string>& labels,
                               const Point3& line_point_uT, const Point3& line_direction, int width_px = 1200,
                               int height_px = 1000);

// The outline of the projection of the ellipsoid onto axes (a, b) (0 = x, 1 = y, 2 = z), as a closed
// polyline of `segments` + 1 points.
std::vector<std::array<double, 2>> ProjectedOutline(const Ellipsoid3D& e, int a, int b, int segments = 96);

}  // namespace hexsim::render
