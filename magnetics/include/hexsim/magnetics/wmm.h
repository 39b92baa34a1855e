// World Magnetic Model (WMM2015v2, WMM2020, WMM2025; the original WMM2015 selectable), coefficients
// compiled in at build time.
//
// Standard WMM algorithm (NOAA technical report): geodetic (WGS-84) -> geocentric spherical
// coordinates, Schmidt semi-normalised associated Legendre functions to degree 12, Gauss
// coefficients advanced by their secular variation g(t) = g + (t - t0)·ġ, field rotated back to the
// geodetic North-East-Down frame. No file I/O.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexsim/common/status.h"

namespace hexsim::magnetics {

// Position on the WGS-84 ellipsoid; alt_m is height above the ellipsoid.
struct GeodeticPoint {
  double lat_deg = 0.0;  // [-90, 90]
  double lon_deg = 0.0;  // any value, east positive
  double alt_m = 0.0;    // WMM validity: -1 km ... 850 km
};

// The main field at a place and date, in the local geodetic NED frame.
struct EarthField {
  Eigen::Vector3d B_N_uT = Eigen::Vector3d::Zero();  // (X north, Y east, Z down)
  double declination_deg = 0.0;   // atan2(Y, X): east of true north positive
  double inclination_deg = 0.0;   // atan2(Z, H): down positive
  double horizontal_uT = 0.0;     // H = |(X, Y)|
  double total_uT = 0.0;          // F = |B|
  std::string model;              // as in the COF header, e.g. "WMM-2025", "WMM-2015v2"
  std::string model_id;           // the selectable id: "wmm2015", "wmm2015v2", "wmm2020", "wmm2025"
};

// Validity limits of the model (WMM technical report).
inline constexpr double kWmmFirstYear = 2015.0;
inline constexpr double kWmmLastYear = 2030.0;
inline constexpr double kWmmMinAlt_m = -1000.0;
inline constexpr double kWmmMaxAlt_m = 850000.0;
inline constexpr double kWmmModelSpan_yr = 5.0;  // each model: epoch … epoch + 5

// Picks the epoch from the date (2015.0–2020.0 → WMM2015v2, 2020.0–2025.0 → WMM2020,
// 2025.0–2030.0 → WMM2025; a boundary year belongs to the newer model, 2030.0 to WMM2025).
// Outside 2015.0–2030.0: kBadInput "decimal_year: ... outside WMM validity 2015.0–2030.0" unless
// allow_extrapolation (then the nearest epoch, its secular variation extrapolated).
// Also kBadInput for a latitude outside [-90, 90], an altitude outside the WMM range, or non-finite input.
Result<EarthField> EvaluateWmm(const GeodeticPoint& where, double decimal_year,
                               bool allow_extrapolation = false);

// Same with an explicit epoch (2015, 2020, 2025; 2015 is WMM2015v2) for tests/tools; any finite
// decimal_year is accepted (the secular variation is extrapolated linearly). Unknown epoch: kBadInput.
Result<EarthField> EvaluateWmmEpoch(int epoch, const GeodeticPoint& where, double decimal_year);

// The compiled-in epochs, ascending (2015, 2020, 2025).
std::vector<int> WmmEpochs();

// A model by id (WmmModelIds()): outside its epoch … epoch + 5 kBadInput "decimal_year: 2021.2
// outside wmm2015 validity 2015.0–2020.0" unless allow_extrapolation. Unknown id: kBadInput.
Result<EarthField> EvaluateWmmModel(const std::string& id, const GeodeticPoint& where, double decimal_year,
                                    bool allow_extrapolation = false);
// "wmm2015", "wmm2015v2", "wmm2020", "wmm2025".
std::vector<std::string> WmmModelIds();

// "2016.5" → 2016.5; "YYYY-MM-DD" → year + (day of year − 1) / days in the year (NOAA's
// convention, 00:00 UTC). Anything else, or a day that does not exist: kBadInput.
Result<double> DecimalYearFromDate(const std::string& text);

}  // namespace hexsim::magnetics
