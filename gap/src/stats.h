// Small statistics helpers for the gap diagnosis (private to gap/).
#pragma once

#include <cmath>
#include <vector>

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

// Two-sided 97.5 % quantile of Student's t with df degrees of freedom (Cornish–Fisher expansion).
inline double StudentT975(double df) {
  const double z = 1.959963984540054;
  const double z3 = z * z * z, z5 = z3 * z * z, z7 = z5 * z * z;
  return z + (z3 + z) / (4 * df) + (5 * z5 + 16 * z3 + 3 * z) / (96 * df * df) +
         (3 * z7 + 19 * z5 + 17 * z3 - 15 * z) / (384 * df * df * df);
}

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

// Regularised incomplete beta I_x(a, b) (continued fraction, modified Lentz).
inline double IncompleteBeta(double a, double b, double x) {
  if (!(x > 0)) return 0.0;
  if (!(x < 1)) return 1.0;
  auto cf = [](double a_, double b_, double x_) {
    constexpr double kTiny = 1e-300;
    double c = 1.0, d = 1.0 - (a_ + b_) * x_ / (a_ + 1.0);
    if (std::fabs(d) < kTiny) d = kTiny;
    d = 1.0 / d;
    double h = d;
    for (int m = 1; m <= 300; ++m) {
      const double m2 = 2.0 * m;
      double aa = m * (b_ - m) * x_ / ((a_ - 1.0 + m2) * (a_ + m2));
      d = 1.0 + aa * d;
      if (std::fabs(d) < kTiny) d = kTiny;
      c = 1.0 + aa / c;
      if (std::fabs(c) < kTiny) c = kTiny;
      d = 1.0 / d;
      h *= d * c;
      aa = -(a_ + m) * (a_ + b_ + m) * x_ / ((a_ + m2) * (a_ + 1.0 + m2));
      d = 1.0 + aa * d;
      if (std::fabs(d) < kTiny) d = kTiny;
      c = 1.0 + aa / c;
      if (std::fabs(c) < kTiny) c = kTiny;
      d = 1.0 / d;
      const double del = d * c;
      h *= del;
      if (std::fabs(del - 1.0) < 1e-12) break;
    }
    return h;
  };
  const double lbeta = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b);
  const double front = std::exp(lbeta + a * std::log(x) + b * std::log1p(-x));
  if (x < (a + 1.0) / (a + b + 2.0)) return front * cf(a, b, x) / a;
  return 1.0 - front * cf(b, a, 1.0 - x) / b;
}

// Upper tail of Fisher's F with (d1, d2) degrees of freedom.
inline double FSf(double f, double d1, double d2) {
  if (!(f > 0)) return 1.0;
  return IncompleteBeta(d2 / 2.0, d1 / 2.0, d2 / (d2 + d1 * f));
}

}  // namespace hexsim::gap::internal
