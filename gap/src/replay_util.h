// Helpers shared by the replay's parts (private to gap/).
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "channels.h"

namespace hexsim::gap::internal {

inline constexpr double kThrottleFullScale = 1000.0;  // control_u units per full throttle
// Lag grid for the current_lag candidate (s): ESC/current filtering to slow magnetisation.
inline constexpr double kLagGrid_s[] = {0.01, 0.02, 0.03, 0.05, 0.07, 0.1, 0.14, 0.2, 0.28, 0.4, 0.56, 0.8, 1.1, 1.6, 2.2};
// The exponent of a lagged current field (current_lag's free member), B ∝ I^p. Physical range
// 1..2: a conductor's field is linear in its current (p = 1); a soft-iron part magnetised by the
// current's own field follows Rayleigh's law, μ = μ_i + ν·H, so its field holds I and I² terms
// (1 < p < 2); no mechanism near a compass grows faster. The grid's last point lies beyond the range,
// so a field that grows faster fits there and is refused as a model mismatch.
inline constexpr double kLagExponentLo = 1.0, kLagExponentHi = 2.0;
inline constexpr double kLagExponents[] = {1.0, 1.25, 1.5, 1.75, 2.0, 2.5};
// The exponent r of a throttle-driven field, B ∝ throttle^r (throttle_hard_iron; pymavlink's
// magfit_compassmot fits r). Physical range 1..3: ArduPilot's COMPASS_MOTCT 1 compensates a field
// linear in the throttle (a lead carrying the throttle's own signal, r = 1), and a field carried by
// the motors' current grows as that current does, faster than the throttle (hexsim's quad reads r = 2,
// a motor's DC power ∝ ω³ bounds it at 3); no throttle-driven source grows slower than the throttle.
// The grid's first point lies below the range, so a field that grows slower (a current field that
// saturates: the out-of-library tanh form fits r = 0.5 in every flight) fits there and is refused as
// a model mismatch instead of being named throttle_hard_iron.
inline constexpr double kThrottleExponentLo = 1.0, kThrottleExponentHi = 3.0;
inline constexpr double kThrottleExponents[] = {0.5, 1.0, 1.5, 2.0, 3.0};

inline const std::vector<double>* Col(const logs::FlightLog& log, const std::string& name) {
  return log.Has(name) ? &log.Column(name) : nullptr;
}

inline bool ColumnHasData(const logs::FlightLog& log, const std::string& name) {
  if (!log.Has(name)) return false;
  for (double v : log.Column(name)) {
    if (std::isfinite(v)) return true;
  }
  return false;
}

// Linear interpolation of the log's rows at time tq (rows ascending in t). Returns false outside.
struct RowCursor {
  const std::vector<double>& t;
  size_t i = 0;
  // Sets (i, w) so that value = (1 − w)·v[i] + w·v[i + 1].
  bool Seek(double tq, double* w) {
    if (t.size() < 2 || tq < t.front() || tq > t.back()) return false;
    while (i + 2 < t.size() && t[i + 1] < tq) ++i;
    while (i > 0 && t[i] > tq) --i;
    const double dt = t[i + 1] - t[i];
    *w = dt > 0 ? std::clamp((tq - t[i]) / dt, 0.0, 1.0) : 0.0;
    return true;
  }
};

inline double Lerp(const std::vector<double>& v, size_t i, double w) {
  if (w <= 0) return v[i];
  return (1 - w) * v[i] + w * v[i + 1];
}

inline Eigen::Quaterniond QuatRow(const std::vector<const std::vector<double>*>& q, size_t i) {
  return Eigen::Quaterniond((*q[0])[i], (*q[1])[i], (*q[2])[i], (*q[3])[i]);
}

inline Eigen::Quaterniond QuatLerp(const std::vector<const std::vector<double>*>& q, size_t i, double w) {
  Eigen::Quaterniond a = QuatRow(q, i);
  if (w <= 0) return a.normalized();
  Eigen::Quaterniond b = QuatRow(q, i + 1);
  if (a.dot(b) < 0) b.coeffs() *= -1.0;
  Eigen::Quaterniond r;
  r.coeffs() = (1 - w) * a.coeffs() + w * b.coeffs();
  return r.normalized();
}


// Median of the finite values (NaN when none).
inline double MedianFinite(const std::vector<double>& v) {
  std::vector<double> f;
  for (double x : v) {
    if (std::isfinite(x)) f.push_back(x);
  }
  if (f.empty()) return std::nan("");
  std::nth_element(f.begin(), f.begin() + static_cast<std::ptrdiff_t>(f.size() / 2), f.end());
  return f[f.size() / 2];
}

inline Mat3X Diag3(double v) { return Mat3X(Eigen::Matrix3d::Identity() * v); }

inline std::string MagPrefix(size_t c) { return c == 0 ? "mag" : fmt::format("mag{}", c + 1); }

// Central-difference derivative of a sample series (one-sided at the ends).
std::vector<Vec3> Derivative(const std::vector<double>& t, const std::vector<Vec3>& v);

}  // namespace hexsim::gap::internal
