#include "hexsim/common/statistics.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hexsim {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Continued fraction of I_x(a, b) (Numerical Recipes' betacf, modified Lentz), valid for
// x < (a + 1)/(a + b + 2); y = 1 − x is passed in so that callers keep its precision.
double BetaContinuedFraction(double a, double b, double x) {
  constexpr double kTiny = 1e-300;
  constexpr double kEps = 1e-15;
  constexpr int kMaxTerms = 1000;
  auto clamp_tiny = [](double v) { return std::fabs(v) < kTiny ? kTiny : v; };
  double c = 1.0;
  double d = 1.0 / clamp_tiny(1.0 - (a + b) * x / (a + 1.0));
  double h = d;
  for (int m = 1; m <= kMaxTerms; ++m) {
    const double m2 = 2.0 * m;
    const double even = m * (b - m) * x / ((a - 1.0 + m2) * (a + m2));
    d = 1.0 / clamp_tiny(1.0 + even * d);
    c = clamp_tiny(1.0 + even / c);
    h *= d * c;
    const double odd = -(a + m) * (a + b + m) * x / ((a + m2) * (a + 1.0 + m2));
    d = 1.0 / clamp_tiny(1.0 + odd * d);
    c = clamp_tiny(1.0 + odd / c);
    const double del = d * c;
    h *= del;
    if (std::fabs(del - 1.0) < kEps) break;
  }
  return h;
}

// I_x(a, b) with both x and y = 1 − x given (each exact where it is small).
double IncompleteBeta(double a, double b, double x, double y) {
  if (!(x > 0)) return 0.0;
  if (!(y > 0)) return 1.0;
  const double log_front = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log(y);
  const double front = std::exp(log_front);
  if (x < (a + 1.0) / (a + b + 2.0)) return front * BetaContinuedFraction(a, b, x) / a;
  return 1.0 - front * BetaContinuedFraction(b, a, y) / b;
}

}  // namespace

double Mean(const std::vector<double>& x) {
  if (x.empty()) return kNaN;
  double sum = 0.0;
  for (double v : x) sum += v;
  return sum / static_cast<double>(x.size());
}

double SampleStd(const std::vector<double>& x) {
  if (x.size() < 2) return kNaN;
  const double mean = Mean(x);
  double ss = 0.0;
  for (double v : x) ss += (v - mean) * (v - mean);
  return std::sqrt(ss / static_cast<double>(x.size() - 1));
}

double RegularizedIncompleteBeta(double a, double b, double x) {
  if (!(a > 0) || !(b > 0) || !(x >= 0 && x <= 1)) return kNaN;
  return IncompleteBeta(a, b, x, 1.0 - x);
}

double InverseRegularizedIncompleteBeta(double a, double b, double p) {
  if (!(a > 0) || !(b > 0) || !(p >= 0 && p <= 1)) return kNaN;
  if (p == 0.0) return 0.0;
  if (p == 1.0) return 1.0;
  // f(x) = I_x(a, b) − p rises from −p to 1 − p; f'(x) = x^(a−1)(1 − x)^(b−1)/B(a, b).
  const double log_beta = std::lgamma(a) + std::lgamma(b) - std::lgamma(a + b);
  double lo = 0.0, hi = 1.0;
  double x = a / (a + b);  // the mean of Beta(a, b): inside the bracket
  constexpr int kMaxIterations = 200;
  for (int i = 0; i < kMaxIterations; ++i) {
    const double f = IncompleteBeta(a, b, x, 1.0 - x) - p;
    if (f == 0.0) return x;
    (f < 0 ? lo : hi) = x;
    const double slope = std::exp((a - 1.0) * std::log(x) + (b - 1.0) * std::log1p(-x) - log_beta);
    double next = x - f / slope;
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);  // Newton left the bracket: bisect
    if (std::fabs(next - x) <= 4 * std::numeric_limits<double>::epsilon() * x || hi - lo <= 1e-300) return next;
    x = next;
  }
  return x;
}

double StudentTCdf(double t, double dof) {
  if (!(dof > 0) || std::isnan(t)) return kNaN;
  // x = ν/(ν + t²), y = 1 − x = t²/(ν + t²); upper tail P(T > |t|) = ½·I_x(ν/2, ½).
  const double t2 = t * t;
  const double tail = 0.5 * IncompleteBeta(0.5 * dof, 0.5, dof / (dof + t2), t2 / (dof + t2));
  return t >= 0 ? 1.0 - tail : tail;
}

double StudentTQuantile(double p, double dof) {
  if (!(dof > 0) || !(p > 0 && p < 1)) return kNaN;
  if (p == 0.5) return 0.0;
  const double q = 2.0 * std::min(p, 1.0 - p);  // two-sided tail mass: I_x(ν/2, ½) = q
  const double a = 0.5 * dof, b = 0.5;
  double t = 0.0;
  if (q <= IncompleteBeta(a, b, 0.5, 0.5)) {
    const double x = InverseRegularizedIncompleteBeta(a, b, q);  // x ≤ ½: exact where small
    t = std::sqrt(dof * (1.0 - x) / x);
  } else {
    const double y = InverseRegularizedIncompleteBeta(b, a, 1.0 - q);  // y = 1 − x < ½
    t = std::sqrt(dof * y / (1.0 - y));
  }
  return p > 0.5 ? t : -t;
}

double StudentT975(double dof) { return StudentTQuantile(0.975, dof); }

SampleStats Summarize(const std::vector<double>& x) {
  SampleStats s;
  s.n = x.size();
  if (s.n == 0) return s;
  s.mean = Mean(x);
  if (s.n >= 2) {
    const double sd = SampleStd(x);
    const double half = StudentT975(static_cast<double>(s.n - 1)) * sd / std::sqrt(static_cast<double>(s.n));
    s.std = sd;
    s.ci95_lo = s.mean - half;
    s.ci95_hi = s.mean + half;
  }
  return s;
}

SampleStats SummarizeNonNegative(const std::vector<double>& x) {
  SampleStats s = Summarize(x);
  if (s.ci95_lo && *s.ci95_lo < 0.0) {
    s.ci95_lo = 0.0;
    s.ci95_clipped = true;
  }
  return s;
}

}  // namespace hexsim
