// Sample statistics and the distributions behind them: mean, sample standard deviation, Student's t
// quantiles (exact at every number of degrees of freedom, through the inverse of the regularised
// incomplete beta function) and the 95 % confidence interval of a mean. One unit for every report
// (compare, batch, gap); standard library only.
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

namespace hexsim {

// x̄ = Σx/n (NaN when x is empty).
double Mean(const std::vector<double>& x);
// s = √(Σ(x − x̄)²/(n − 1)), the sample standard deviation (NaN when n < 2).
double SampleStd(const std::vector<double>& x);

// I_x(a, b) = B(x; a, b)/B(a, b) for a, b > 0 and x in [0, 1] (continued fraction, modified Lentz;
// relative accuracy ~1e-14). NaN for arguments outside those ranges.
double RegularizedIncompleteBeta(double a, double b, double x);
// The x in [0, 1] with I_x(a, b) = p, for p in [0, 1] (Newton steps kept inside a bisection bracket).
double InverseRegularizedIncompleteBeta(double a, double b, double p);

// P(T ≤ t) for Student's t with ν > 0 degrees of freedom: 1 − ½·I_{ν/(ν+t²)}(ν/2, ½) for t ≥ 0.
double StudentTCdf(double t, double dof);
// The t with P(T ≤ t) = p, p in (0, 1), ν > 0 (not necessarily an integer): exact to ~1e-12 relative,
// e.g. t_{0.975,1} = tan(0.475π) = 12.7062, t_{0.975,2} = 4.3027. NaN outside those ranges.
double StudentTQuantile(double p, double dof);
// t_{0.975, ν}: the half-width factor of a two-sided 95 % interval.
double StudentT975(double dof);

// A sample summarised: n, mean, and (n ≥ 2) the sample standard deviation and the 95 % confidence
// interval of the mean, x̄ ± t_{0.975, n−1}·s/√n.
struct SampleStats {
  size_t n = 0;
  double mean = 0.0;                       // 0 when n = 0
  std::optional<double> std;               // n ≥ 2
  std::optional<double> ci95_lo, ci95_hi;  // n ≥ 2
  bool ci95_clipped = false;               // ci95_lo raised to 0 (SummarizeNonNegative)
};
SampleStats Summarize(const std::vector<double>& x);
// The same for a quantity that cannot be negative (an error magnitude, a distance, an energy): the
// interval's lower end is clipped at 0 and `ci95_clipped` says so. With few, skewed samples the
// t interval x̄ ± t·s/√n can reach below zero although no sample, and no mean, can; the clipped
// interval still holds the mean with at least the stated confidence, since only impossible values
// were removed.
SampleStats SummarizeNonNegative(const std::vector<double>& x);

}  // namespace hexsim
