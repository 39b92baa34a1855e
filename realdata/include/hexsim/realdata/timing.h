// Timing of real logs: how late one signal is against another (compass against attitude, current
// against throttle), from a lag scan with block-bootstrap intervals.
//
// A lag profile is the sum of squared errors of some fit as a function of a trial lag L, kept per
// contiguous time block: SSE(L) = Σ_b SSE_b(L). The estimate is its argmin, refined by a parabola
// through the neighbouring grid points; the 95 % interval is the percentile interval of the argmin
// over block-bootstrap resamples (blocks drawn with replacement, long against the residual's
// correlation time, so the interval holds for coloured residuals), never narrower than ± half a grid
// step (the parabola's resolution).
#pragma once

#include <cstdint>
#include <vector>

namespace hexsim::realdata {

struct LagEstimate {
  double value_s;
  double ci95_s[2];
  bool at_grid_edge = false;   // the argmin sits on the first or last grid point: not resolved
  bool unbounded = false;      // the 95 % interval reaches the first or last grid point: the data do
                               // not bound the lag on that side (a flat profile), not resolved
  double share = 0.0;          // 1 − SSE(value)/SSE(0): the part of the error the alignment removes
  std::vector<double> grid_s;  // the profile, for reports
  std::vector<double> sse;
  LagEstimate();
  bool ok() const;
  bool resolved() const;  // ok, its argmin inside the grid and its interval bounded on both sides
};

// The profile's estimate from per-block SSE, sse_by_lag[i][b] for grid_s[i] (ascending).
LagEstimate ProfileLag(const std::vector<double>& grid_s, const std::vector<std::vector<double>>& sse_by_lag,
                       int resamples = 200, uint64_t seed = 1);

// A grid from lo_s to hi_s in steps of step_s (both ends included).
std::vector<double> LagGrid(double lo_s, double hi_s, double step_s);

struct StalenessOptions {
  double min_lag_s = -0.3;  // a signal can lead as well as lag
  double max_lag_s = 0.8;
  double step_s = 0.02;
  int blocks = 20;
  int resamples = 200;
  int poly_degree = 2;  // y = Σ_j c_j·x^j: current ∝ throttle^~1.5 is close to a quadratic
  uint64_t seed = 1;
};

// How stale y is against x: y(t) ≈ f(x(t − L)), f a polynomial fitted at each trial L. y is given at
// its own sample times ty (each logged sample once), x at its own (tx ascending, interpolated
// linearly between samples). Samples where x(t − L) is unavailable for some L are left out.
LagEstimate StalenessScan(const std::vector<double>& tx, const std::vector<double>& x, const std::vector<double>& ty,
                          const std::vector<double>& y, const StalenessOptions& options = {});

// A sample-and-hold channel (a current sensor read at 5 Hz and logged at 10 Hz): a value repeated
// on later rows is the same sample, held, and was measured no later than where it first appears.
// The samples are the value changes, each stamped where it first appears (ts, its own stamp column,
// where finite, else t). A value repeated for longer than twice the median sample interval is
// constant, not held: it is stamped again where it last appears.
struct HeldSamples {
  std::vector<double> t, v;
};
HeldSamples FirstAppearances(const std::vector<double>& t, const std::vector<double>& ts, const std::vector<double>& v);
// The samples linearly interpolated at tq (ascending), the ends held; NaN without samples.
std::vector<double> InterpolateSamples(const HeldSamples& s, const std::vector<double>& tq);

}  // namespace hexsim::realdata
