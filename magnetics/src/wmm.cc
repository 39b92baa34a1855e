#include "hexsim/magnetics/wmm.h"

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "hexsim/common/format.h"
#include "hexsim/common/rotation.h"
#include "wmm_coefficients.h"

namespace hexsim::magnetics {
namespace {

using internal::kWmmCoefficientCount;
using internal::kWmmMaxDegree;
using internal::WmmCoefficients;
using internal::WmmIndex;

// WGS-84 ellipsoid and the WMM reference radius.
constexpr double kWgs84A_km = 6378.137;
constexpr double kWgs84InvF = 298.257223563;
constexpr double kWmmRefRadius_km = 6371.2;
constexpr double kNtPerUt = 1000.0;

// Shortest round-trip form: 2030.4 prints as 2030.4 (a %.4g format printed "2030").
std::string FormatYear(double y) { return ShortestDouble(y); }

// The default model of an epoch: the last table with it (WMM2015v2 over WMM2015).
const WmmCoefficients* FindEpoch(int epoch) {
  int count = 0;
  const WmmCoefficients* tables = internal::WmmTables(&count);
  const WmmCoefficients* found = nullptr;
  for (int i = 0; i < count; ++i) {
    if (tables[i].epoch == epoch) found = &tables[i];
  }
  return found;
}

Status CheckPoint(const GeodeticPoint& where) {
  if (!std::isfinite(where.lat_deg) || where.lat_deg < -90.0 || where.lat_deg > 90.0) {
    return Status::BadInput("lat_deg: " + std::to_string(where.lat_deg) + " outside [-90, 90]");
  }
  if (!std::isfinite(where.lon_deg)) return Status::BadInput("lon_deg: not a finite number");
  if (!std::isfinite(where.alt_m) || where.alt_m < kWmmMinAlt_m || where.alt_m > kWmmMaxAlt_m) {
    return Status::BadInput("alt_m: " + std::to_string(where.alt_m) +
                            " outside WMM validity -1000 m to 850000 m");
  }
  return Status::Ok();
}

// Field in geodetic NED (nT) from one coefficient set.
EarthField Evaluate(const WmmCoefficients& c, const GeodeticPoint& where, double decimal_year) {
  // Geodetic -> geocentric spherical (WGS-84).
  const double f = 1.0 / kWgs84InvF;
  const double e2 = f * (2.0 - f);
  const double lat = where.lat_deg * kDegToRad;
  const double lon = where.lon_deg * kDegToRad;
  const double alt_km = where.alt_m / 1000.0;
  const double sin_lat = std::sin(lat);
  const double cos_lat = std::cos(lat);
  const double rc_km = kWgs84A_km / std::sqrt(1.0 - e2 * sin_lat * sin_lat);  // prime vertical radius
  const double p_km = (rc_km + alt_km) * cos_lat;
  const double z_km = (rc_km * (1.0 - e2) + alt_km) * sin_lat;
  const double r_km = std::hypot(p_km, z_km);
  const double lat_c = std::asin(z_km / r_km);  // geocentric latitude φ'

  // Colatitude θ = π/2 − φ': cos θ = sin φ', sin θ = cos φ' (>= 0).
  const double cos_t = std::sin(lat_c);
  const double sin_t = std::cos(lat_c);

  // Schmidt semi-normalised P_n^m(cos θ), dP_n^m/dθ, and S_n^m = P_n^m / sin θ for m >= 1 (the latter
  // from the same recursions seeded with P_m^m / sin θ, so the east component needs no division by
  // sin θ and stays finite at the poles).
  std::array<double, kWmmCoefficientCount> P{};
  std::array<double, kWmmCoefficientCount> dP{};
  std::array<double, kWmmCoefficientCount> S{};
  P[0] = 1.0;
  dP[0] = 0.0;
  S[0] = 0.0;
  for (int n = 1; n <= kWmmMaxDegree; ++n) {
    // Diagonal: P_n^n = sqrt((2n−1)/(2n))·sin θ·P_{n−1}^{n−1} (P_1^1 = sin θ).
    const double k = (n == 1) ? 1.0 : std::sqrt((2.0 * n - 1.0) / (2.0 * n));
    const int nn = WmmIndex(n, n);
    const int pp = WmmIndex(n - 1, n - 1);
    P[nn] = k * sin_t * P[pp];
    dP[nn] = k * (sin_t * dP[pp] + cos_t * P[pp]);
    S[nn] = (n == 1) ? 1.0 : k * sin_t * S[pp];
    // Column: P_n^m = ((2n−1) cos θ P_{n−1}^m − sqrt((n−1)² − m²) P_{n−2}^m) / sqrt(n² − m²).
    for (int m = 0; m < n; ++m) {
      const int i = WmmIndex(n, m);
      const int i1 = WmmIndex(n - 1, m);
      const double inv = 1.0 / std::sqrt(double(n * n - m * m));
      const double a = 2.0 * n - 1.0;
      double b = 0.0;
      double p2 = 0.0, dp2 = 0.0, s2 = 0.0;
      if (n - 2 >= m) {
        const int i2 = WmmIndex(n - 2, m);
        b = std::sqrt(double((n - 1) * (n - 1) - m * m));
        p2 = P[i2];
        dp2 = dP[i2];
        s2 = S[i2];
      }
      P[i] = (a * cos_t * P[i1] - b * p2) * inv;
      dP[i] = (a * (cos_t * dP[i1] - sin_t * P[i1]) - b * dp2) * inv;
      S[i] = (m == 0) ? 0.0 : (a * cos_t * S[i1] - b * s2) * inv;
    }
  }

  // Spherical-harmonic sums; coefficients advanced by their secular variation.
  const double dt_yr = decimal_year - c.epoch_year;
  const double ratio = kWmmRefRadius_km / r_km;
  double x_nT = 0.0, y_nT = 0.0, z_nT = 0.0;  // geocentric north, east, down
  double ratio_pow = ratio * ratio;          // (a/r)^(n+2), starts at n = 0
  std::array<double, kWmmMaxDegree + 1> cos_ml{};
  std::array<double, kWmmMaxDegree + 1> sin_ml{};
  for (int m = 0; m <= kWmmMaxDegree; ++m) {
    cos_ml[m] = std::cos(m * lon);
    sin_ml[m] = std::sin(m * lon);
  }
  for (int n = 1; n <= kWmmMaxDegree; ++n) {
    ratio_pow *= ratio;
    for (int m = 0; m <= n; ++m) {
      const int i = WmmIndex(n, m);
      const double g = c.g_nT[i] + dt_yr * c.g_dot_nTpyr[i];
      const double h = c.h_nT[i] + dt_yr * c.h_dot_nTpyr[i];
      const double gc_hs = g * cos_ml[m] + h * sin_ml[m];
      const double gs_hc = g * sin_ml[m] - h * cos_ml[m];
      x_nT += ratio_pow * gc_hs * dP[i];                  // X = (1/r) ∂V/∂θ
      y_nT += ratio_pow * m * gs_hc * S[i];               // Y = −(1/(r sin θ)) ∂V/∂λ
      z_nT -= ratio_pow * (n + 1) * gc_hs * P[i];         // Z = ∂V/∂r
    }
  }

  // Rotate from geocentric to geodetic NED by the latitude difference ψ = φ' − φ.
  const double psi = lat_c - lat;
  const double X = x_nT * std::cos(psi) - z_nT * std::sin(psi);
  const double Z = x_nT * std::sin(psi) + z_nT * std::cos(psi);
  const double Y = y_nT;

  EarthField out;
  out.B_N_uT = Eigen::Vector3d(X, Y, Z) / kNtPerUt;
  out.horizontal_uT = std::hypot(X, Y) / kNtPerUt;
  out.total_uT = out.B_N_uT.norm();
  out.declination_deg = std::atan2(Y, X) * kRadToDeg;
  out.inclination_deg = std::atan2(Z, std::hypot(X, Y)) * kRadToDeg;
  out.model = c.model;
  out.model_id = c.id;
  return out;
}

}  // namespace

std::vector<int> WmmEpochs() {
  int count = 0;
  const WmmCoefficients* tables = internal::WmmTables(&count);
  std::vector<int> epochs;
  for (int i = 0; i < count; ++i) {
    if (epochs.empty() || epochs.back() != tables[i].epoch) epochs.push_back(tables[i].epoch);
  }
  return epochs;
}

std::vector<std::string> WmmModelIds() {
  int count = 0;
  const WmmCoefficients* tables = internal::WmmTables(&count);
  std::vector<std::string> ids;
  ids.reserve(static_cast<size_t>(count));
  for (int i = 0; i < count; ++i) ids.emplace_back(tables[i].id);
  return ids;
}

Result<EarthField> EvaluateWmmModel(const std::string& id, const GeodeticPoint& where, double decimal_year,
                                    bool allow_extrapolation) {
  int count = 0;
  const WmmCoefficients* tables = internal::WmmTables(&count);
  const WmmCoefficients* c = nullptr;
  std::string all;
  for (int i = 0; i < count; ++i) {
    if (id == tables[i].id) c = &tables[i];
    all += std::string(all.empty() ? "" : ", ") + tables[i].id;
  }
  if (c == nullptr) return Status::BadInput(Format("model: unknown WMM model '%s' (one of: %s)", id.c_str(), all.c_str()));
  if (!std::isfinite(decimal_year)) return Status::BadInput("decimal_year: not a finite number");
  const double last = c->epoch_year + kWmmModelSpan_yr;
  if (!allow_extrapolation && (decimal_year < c->epoch_year || decimal_year > last)) {
    return Status::BadInput(Format("decimal_year: %s outside %s validity %.1f–%.1f", FormatYear(decimal_year).c_str(),
                                   id.c_str(), c->epoch_year, last));
  }
  HEXSIM_RETURN_IF_ERROR(CheckPoint(where));
  return Evaluate(*c, where, decimal_year);
}

Result<double> DecimalYearFromDate(const std::string& text) {
  char* end = nullptr;
  const double plain = std::strtod(text.c_str(), &end);
  if (!text.empty() && end == text.c_str() + text.size() && std::isfinite(plain)) return plain;
  int y = 0, m = 0, d = 0;
  char tail = 0;
  if (text.size() != 10 || std::sscanf(text.c_str(), "%4d-%2d-%2d%c", &y, &m, &d, &tail) != 3 || text[4] != '-' ||
      text[7] != '-') {
    return Status::BadInput("date: '" + text + "': expected a decimal year (2016.5) or YYYY-MM-DD");
  }
  const bool leap = (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
  static const int kDays[12] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  if (m < 1 || m > 12 || d < 1 || d > kDays[m - 1] + (m == 2 && leap ? 1 : 0)) {
    return Status::BadInput("date: '" + text + "': no such day");
  }
  int day_of_year = d - 1;
  for (int k = 0; k < m - 1; ++k) day_of_year += kDays[k] + (k == 1 && leap ? 1 : 0);
  // NOAA's convention (WMM software): year + (day of year − 1) / days in the year, at 00:00 UTC.
  return y + day_of_year / (leap ? 366.0 : 365.0);
}

Result<EarthField> EvaluateWmmEpoch(int epoch, const GeodeticPoint& where, double decimal_year) {
  const WmmCoefficients* c = FindEpoch(epoch);
  if (c == nullptr) {
    return Status::BadInput("epoch: " + std::to_string(epoch) + " is not a compiled-in WMM epoch (2015, 2020, 2025)");
  }
  if (!std::isfinite(decimal_year)) return Status::BadInput("decimal_year: not a finite number");
  HEXSIM_RETURN_IF_ERROR(CheckPoint(where));
  return Evaluate(*c, where, decimal_year);
}

Result<EarthField> EvaluateWmm(const GeodeticPoint& where, double decimal_year, bool allow_extrapolation) {
  if (!std::isfinite(decimal_year)) return Status::BadInput("decimal_year: not a finite number");
  if (!allow_extrapolation && (decimal_year < kWmmFirstYear || decimal_year > kWmmLastYear)) {
    return Status::BadInput("decimal_year: " + FormatYear(decimal_year) +
                            " outside WMM validity 2015.0–2030.0");
  }
  // The newest epoch not after the date; dates before the first epoch use the first.
  int count = 0;
  const WmmCoefficients* tables = internal::WmmTables(&count);
  HEXSIM_CHECK(count > 0);
  const WmmCoefficients* chosen = &tables[0];
  for (int i = 0; i < count; ++i) {
    if (decimal_year >= tables[i].epoch_year) chosen = &tables[i];
  }
  return EvaluateWmmEpoch(chosen->epoch, where, decimal_year);
}

}  // namespace hexsim::magnetics
