// Lag profiles with block-bootstrap intervals (see timing.h).
#include "hexsim/realdata/timing.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "hexsim/common/rng.h"

namespace hexsim::realdata {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Argmin of a profile with a parabola through the minimum and its neighbours.
double RefinedArgmin(const std::vector<double>& g, const std::vector<double>& s, bool* edge) {
  const size_t i = static_cast<size_t>(std::min_element(s.begin(), s.end()) - s.begin());
  *edge = i == 0 || i + 1 == s.size();
  if (*edge) return g[i];
  const double a = s[i - 1], b = s[i], c = s[i + 1];
  const double den = a - 2 * b + c;
  if (!(den > 0)) return g[i];
  const double d = std::clamp(0.5 * (a - c) / den, -0.5, 0.5);  // in grid steps
  return g[i] + d * (d > 0 ? g[i + 1] - g[i] : g[i] - g[i - 1]);
}

double Interp(const std::vector<double>& t, const std::vector<double>& v, double tq) {
  auto it = std::upper_bound(t.begin(), t.end(), tq);
  if (it == t.begin() || it == t.end()) return kNaN;
  const size_t i = static_cast<size_t>(it - t.begin());
  const double dt = t[i] - t[i - 1];
  const double w = dt > 0 ? (tq - t[i - 1]) / dt : 0.0;
  return (1 - w) * v[i - 1] + w * v[i];
}

}  // namespace

LagEstimate::LagEstimate() : value_s(kNaN), ci95_s{kNaN, kNaN} {}

bool LagEstimate::ok() const { return std::isfinite(value_s); }

bool LagEstimate::resolved() const { return ok() && !at_grid_edge && !unbounded; }

std::vector<double> LagGrid(double lo_s, double hi_s, double step_s) {
  std::vector<double> g;
  if (!(step_s > 0) || !(hi_s >= lo_s)) return g;
  const int k = static_cast<int>(std::floor((hi_s - lo_s) / step_s + 1e-9));
  for (int i = 0; i <= k; ++i) g.push_back(lo_s + i * step_s);
  return g;
}

LagEstimate ProfileLag(const std::vector<double>& grid_s, const std::vector<std::vector<double>>& sse_by_lag,
                       int resamples, uint64_t seed) {
  LagEstimate e;
  const size_t L = grid_s.size();
  if (L < 3 || sse_by_lag.size() != L || sse_by_lag[0].empty()) return e;
  const size_t G = sse_by_lag[0].size();
  e.grid_s = grid_s;
  e.sse.assign(L, 0.0);
  for (size_t i = 0; i < L; ++i) {
    for (double v : sse_by_lag[i]) e.sse[i] += v;
  }
  e.value_s = RefinedArgmin(grid_s, e.sse, &e.at_grid_edge);
  // SSE at zero lag (nearest grid point) for the share.
  size_t i0 = 0;
  for (size_t i = 0; i < L; ++i) {
    if (std::fabs(grid_s[i]) < std::fabs(grid_s[i0])) i0 = i;
  }
  const double best = *std::min_element(e.sse.begin(), e.sse.end());
  e.share = e.sse[i0] > 0 ? 1.0 - best / e.sse[i0] : 0.0;
  RngStream rng(seed, "lag_bootstrap");
  std::vector<double> boot;
  std::vector<double> s(L);
  for (int r = 0; r < resamples; ++r) {
    std::fill(s.begin(), s.end(), 0.0);
    for (size_t k = 0; k < G; ++k) {
      const size_t b = std::min(G - 1, static_cast<size_t>(rng.Uniform() * static_cast<double>(G)));
      for (size_t i = 0; i < L; ++i) s[i] += sse_by_lag[i][b];
    }
    bool edge = false;
    boot.push_back(RefinedArgmin(grid_s, s, &edge));
  }
  // The parabola resolves the lag to about half a grid step: the interval is never narrower.
  const double half_step = 0.5 * (grid_s[L - 1] - grid_s[0]) / static_cast<double>(L - 1);
  e.ci95_s[0] = e.value_s - half_step;
  e.ci95_s[1] = e.value_s + half_step;
  if (boot.empty()) return e;
  std::sort(boot.begin(), boot.end());
  const double n = static_cast<double>(boot.size() - 1);
  const double lo = boot[static_cast<size_t>(std::floor(0.025 * n))];
  const double hi = boot[static_cast<size_t>(std::ceil(0.975 * n))];
  e.ci95_s[0] = std::min(e.ci95_s[0], lo);
  e.ci95_s[1] = std::max(e.ci95_s[1], hi);
  // A bootstrap argmin on the grid's end is a resample that prefers a lag beyond the scan.
  e.unbounded = lo <= grid_s[0] || hi >= grid_s[L - 1];
  return e;
}

LagEstimate StalenessScan(const std::vector<double>& tx, const std::vector<double>& x, const std::vector<double>& ty,
                          const std::vector<double>& y, const StalenessOptions& o) {
  const std::vector<double> grid = LagGrid(o.min_lag_s, o.max_lag_s, o.step_s);
  if (tx.size() < 10 || ty.size() < 10 || grid.size() < 3) return LagEstimate();
  // Samples usable at every lag.
  std::vector<size_t> use;
  for (size_t k = 0; k < ty.size(); ++k) {
    if (!std::isfinite(y[k])) continue;
    if (ty[k] - o.max_lag_s <= tx.front() || ty[k] - o.min_lag_s >= tx.back()) continue;
    use.push_back(k);
  }
  const int G = std::max(2, std::min(o.blocks, static_cast<int>(use.size() / 20)));
  if (use.size() < 40) return LagEstimate();
  const int p = o.poly_degree + 1;
  std::vector<std::vector<double>> sse(grid.size(), std::vector<double>(static_cast<size_t>(G), 0.0));
  std::vector<double> xs(use.size());
  for (size_t i = 0; i < grid.size(); ++i) {
    bool finite = true;
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(p, p);
    Eigen::VectorXd g = Eigen::VectorXd::Zero(p);
    Eigen::VectorXd phi(p);
    for (size_t m = 0; m < use.size(); ++m) {
      xs[m] = Interp(tx, x, ty[use[m]] - grid[i]);
      if (!std::isfinite(xs[m])) {
        finite = false;
        break;
      }
      double v = 1;
      for (int j = 0; j < p; ++j, v *= xs[m]) phi[j] = v;
      A.noalias() += phi * phi.transpose();
      g += phi * y[use[m]];
    }
    if (!finite) return LagEstimate();
    const double tr = A.trace();
    const Eigen::VectorXd c = (A + Eigen::MatrixXd::Identity(p, p) * 1e-12 * tr).ldlt().solve(g);
    for (size_t m = 0; m < use.size(); ++m) {
      double v = 1, f = 0;
      for (int j = 0; j < p; ++j, v *= xs[m]) f += c[j] * v;
      const size_t b = m * static_cast<size_t>(G) / use.size();
      const double r = y[use[m]] - f;
      sse[i][b] += r * r;
    }
  }
  return ProfileLag(grid, sse, o.resamples, o.seed);
}

HeldSamples FirstAppearances(const std::vector<double>& t, const std::vector<double>& ts, const std::vector<double>& v) {
  // Runs of equal values: [first row, last row] each.
  struct Run {
    double t_first, t_last, v;
  };
  std::vector<Run> runs;
  double last_t = -std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < v.size() && i < t.size(); ++i) {
    if (!std::isfinite(v[i])) continue;
    const double ti = i < ts.size() && std::isfinite(ts[i]) ? ts[i] : t[i];
    if (!std::isfinite(ti) || ti < last_t) continue;
    last_t = ti;
    if (!runs.empty() && runs.back().v == v[i]) {
      runs.back().t_last = ti;
    } else {
      runs.push_back({ti, ti, v[i]});
    }
  }
  HeldSamples s;
  if (runs.empty()) return s;
  std::vector<double> gaps;
  for (size_t k = 1; k < runs.size(); ++k) gaps.push_back(runs[k].t_first - runs[k - 1].t_first);
  double dt = 0;
  if (!gaps.empty()) {
    std::nth_element(gaps.begin(), gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 2), gaps.end());
    dt = gaps[gaps.size() / 2];
  }
  for (const Run& r : runs) {
    if (!s.t.empty() && r.t_first <= s.t.back()) continue;
    s.t.push_back(r.t_first);
    s.v.push_back(r.v);
    if (dt > 0 && r.t_last - r.t_first > 2 * dt) {
      s.t.push_back(r.t_last);
      s.v.push_back(r.v);
    }
  }
  return s;
}

std::vector<double> InterpolateSamples(const HeldSamples& s, const std::vector<double>& tq) {
  std::vector<double> out(tq.size(), std::numeric_limits<double>::quiet_NaN());
  if (s.t.empty()) return out;
  size_t j = 0;
  for (size_t i = 0; i < tq.size(); ++i) {
    const double q = tq[i];
    if (!std::isfinite(q)) continue;
    while (j + 1 < s.t.size() && s.t[j + 1] <= q) ++j;
    if (q <= s.t.front()) {
      out[i] = s.v.front();
    } else if (j + 1 >= s.t.size()) {
      out[i] = s.v.back();
    } else {
      const double w = (q - s.t[j]) / (s.t[j + 1] - s.t[j]);
      out[i] = (1 - w) * s.v[j] + w * s.v[j + 1];
    }
  }
  return out;
}

}  // namespace hexsim::realdata
