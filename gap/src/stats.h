// Small statistics helpers for the gap diagnosis (private to gap/).
#pragma once

#include <cmath>
#include <vector>

#include "hexsim/common/statistics.h"

namespace hexsim::gap::internal {

// Upper tail of the standard normal.
inline double NormalSf(double z) { return 0.5 * std::erfc(z / std::sqrt(2.0)); }

// Upper tail of chi-square with k degrees of freedom (Wilson–Hilferty; accurate to ~1e-3 relative
// in the range used for decisions, and exact in the limit of large k).
inline double ChiSquareSf(double x, double k) {
  if (!(x > 0)) return 1.0;
  const double a = 2.0 / (9.0 * k);
  const double z = (std::cbrt(x / k) - (1.0 - a)) / std::sqrt(a);
  return NormalSf(z);
}

// Student's t quantile and the regularised incomplete beta: one implementation, in common/.
using hexsim::StudentT975;

// Ljung–Box Q over lags 1..h of a zero-mean-tested series; returns the p-value (chi-square, h dof).
inline double LjungBoxP(const std::vector<double>& x, int h) {
  const size_t n = x.size();
  if (n < 4 * static_cast<size_t>(h)) return 1.0;
  double mean = 0;
  for (double v : x) mean += v;
  mean /= static_cast<double>(n);
  double c0 = 0;
  for (double v : x) c0 += (v - mean) * (v - mean);
  if (!(c0 > 0)) return 1.0;
  double q = 0;
  for (int k = 1; k <= h; ++k) {
    double ck = 0;
    for (size_t i = static_cast<size_t>(k); i < n; ++i) ck += (x[i] - mean) * (x[i - k] - mean);
    const double rk = ck / c0;
    q += rk * rk / static_cast<double>(n - static_cast<size_t>(k));
  }
  q *= static_cast<double>(n) * (static_cast<double>(n) + 2.0);
  return ChiSquareSf(q, h);
}

}  // namespace hexsim::gap::internal

namespace hexsim::gap::internal {

// Upper tail of Fisher's F with (d1, d2) degrees of freedom.
inline double FSf(double f, double d1, double d2) {
  if (!(f > 0)) return 1.0;
  return RegularizedIncompleteBeta(d2 / 2.0, d1 / 2.0, d2 / (d2 + d1 * f));
}

}  // namespace hexsim::gap::internal
