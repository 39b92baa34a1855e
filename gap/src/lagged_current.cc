// current_lag's free member (channels.h, AddLaggedCurrentField): a field the vehicle file does not
// model that follows the current through a first-order lag τ and grows as a power p of it (eddy
// currents in a frame plate, a slow current sensor, a soft-iron part magnetised by the current's own
// field). The configured-wiring member (replay_compass.cc) lags only the field the vehicle file
// models; this one has a free direction, so a withheld lagged field is described too.
// And the timing scan's measurement of such a field's lag behind the logged current (nuisance.h,
// ScanCurrentFieldLag), beside the wires' own unlagged field, whatever effect the channel names.
#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Cholesky>

#include "channels.h"
#include "nuisance.h"
#include "hexsim/common/plausibility.h"
#include "hexsim/realdata/timing.h"
#include "replay_util.h"

namespace hexsim::gap::internal {
namespace {

// Below this flight median current there is no current-driven field to lag (a power monitor that
// reads nothing, or motors idle): 0.5 A is the least a single motor draws carrying any weight.
constexpr double kMinMedianCurrent_A = 0.5;
// The field-lag scan's step: half the 10 Hz period at which autopilots log the current (finer steps
// resolve nothing the samples hold; the profile's parabola refines within a step).
constexpr double kFieldLagStep_s = 0.05;

double MedianPositive(const std::vector<double>& v) {
  std::vector<double> s;
  s.reserve(v.size());
  for (double x : v) s.push_back(std::isfinite(x) ? std::max(0.0, x) : 0.0);
  if (s.empty()) return 0.0;
  std::nth_element(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(s.size() / 2), s.end());
  return s[s.size() / 2];
}

// I through a first-order lag τ over the samples' own times (τ = 0: I itself). A gap between samples
// much longer than τ restarts the filter at the current (exp(−dt/τ) → 0), as at the first sample.
std::vector<double> Lag(const std::vector<double>& t, const std::vector<double>& I, double tau) {
  std::vector<double> y(I.size());
  double a = 0;
  for (size_t k = 0; k < I.size(); ++k) {
    const double x = std::max(0.0, I[k]);
    if (k == 0 || tau <= 0) {
      a = x;
    } else {
      const double alpha = std::exp(-(t[k] - t[k - 1]) / tau);
      a = alpha * a + (1.0 - alpha) * x;
    }
    y[k] = a;
  }
  return y;
}

// The logged current through a first-order lag τ, run over the current's own samples (each where it
// first appears: the whole log, so that the lag's state at a flight sample holds the current's
// history before it, the ground run-up and the rows outside the diagnosed windows, as the field
// did), the current linear between samples as the replay interpolates it (the exact solution of
// τ·ẏ = x − y for an input linear over each step), read at the times t_q. τ = 0: the current itself.
// A negative reading is no current (clipped at 0); NaN outside the samples.
std::vector<double> LaggedCurrentAt(const std::vector<double>& ts, const std::vector<double>& I,
                                    const std::vector<double>& t_q, double tau) {
  std::vector<double> y(I.size());
  double last = 0.0;
  for (size_t k = 0; k < I.size(); ++k) {
    const double x = std::isfinite(I[k]) ? std::max(0.0, I[k]) : last;
    const double x0 = last;
    last = x;
    if (k == 0 || tau <= 0) {
      y[k] = x;
      continue;
    }
    const double dt = std::max(0.0, ts[k] - ts[k - 1]);
    const double alpha = std::exp(-dt / tau);
    // The input's ramp over the step: (τ/dt)·(1 − α) → 1 as dt → 0.
    const double ramp = dt > 0 ? tau / dt * (1.0 - alpha) : 1.0;
    y[k] = alpha * y[k - 1] + (1.0 - alpha) * x0 + (x - x0) * (1.0 - ramp);
  }
  std::vector<double> out(t_q.size(), std::nan(""));
  RowCursor cur{ts};
  double w = 0;
  for (size_t k = 0; k < t_q.size(); ++k) {
    if (cur.Seek(t_q[k], &w)) out[k] = Lerp(y, cur.i, w);
  }
  return out;
}

}  // namespace

void AddLaggedCurrentField(ChannelData* ch, double exponent) {
  const size_t n = ch->t.size();
  const double I_ref = n == ch->current_A.size() ? MedianPositive(ch->current_A) : 0.0;
  if (!(n > 0 && I_ref >= kMinMedianCurrent_A)) {
    ch->not_available.emplace_back("current_lag's free member (flight median current under 0.5 A)");
    return;
  }
  std::vector<double> taus = {0.0};
  taus.insert(taus.end(), std::begin(kLagGrid_s), std::end(kLagGrid_s));
  for (double tau : taus) {
    const std::vector<double> lagged = Lag(ch->t, ch->current_A, tau);
    for (double p : kLagExponents) {
      if (!std::isnan(exponent) && p != exponent) continue;
      // d: the field at the flight's median current over that current (µT/A), so that p = 1, τ = 0
      // is current_hard_iron's k·I.
      Candidate c = MakeCandidate("current_lag", {"d_x_uT_per_A", "d_y_uT_per_A", "d_z_uT_per_A"}, {1, 1, 1}, "s",
                                  "current_A");
      c.grid_name = "tau_s";
      c.grid_value = tau;
      c.grid2_name = "exponent";
      c.grid2_value = p;
      c.X.reserve(n);
      c.regressor = ch->current_A;
      for (size_t k = 0; k < n; ++k) c.X.push_back(Diag3(I_ref * std::pow(lagged[k] / I_ref, p)));
      ch->candidates.push_back(std::move(c));
    }
  }
}

namespace {

// Per-block SSE of y = baseline·β + a·I_a + d·I_ref·(lp_τ(I)/I_ref)^p over the channel's samples,
// for one lagged regressor g (the rest fixed: their normal equations given). Empty on a failed solve.
struct FixedNormal {
  Eigen::Matrix<double, 9, 9> A;  // Σ FᵀF of the fixed columns (baseline 6, instantaneous current 3)
  Eigen::Matrix<double, 9, 1> b;  // Σ Fᵀy
  std::vector<Eigen::Matrix<double, 3, 9>> F;
};

std::vector<double> BlockSse(const FixedNormal& fx, const std::vector<Vec3>& y, const std::vector<double>& g, int G) {
  const size_t n = y.size();
  Eigen::Matrix<double, 12, 12> A = Eigen::Matrix<double, 12, 12>::Zero();
  Eigen::Matrix<double, 12, 1> b = Eigen::Matrix<double, 12, 1>::Zero();
  A.topLeftCorner<9, 9>() = fx.A;
  b.head<9>() = fx.b;
  Eigen::Matrix<double, 9, 3> cross = Eigen::Matrix<double, 9, 3>::Zero();
  double gg = 0;
  Vec3 gy = Vec3::Zero();
  for (size_t k = 0; k < n; ++k) {
    cross.noalias() += g[k] * fx.F[k].transpose();
    gg += g[k] * g[k];
    gy += g[k] * y[k];
  }
  A.topRightCorner<9, 3>() = cross;
  A.bottomLeftCorner<3, 9>() = cross.transpose();
  A.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * gg;
  b.tail<3>() = gy;
  const Eigen::LDLT<Eigen::Matrix<double, 12, 12>> ldlt(A + Eigen::Matrix<double, 12, 12>::Identity() * 1e-12 * A.trace());
  if (ldlt.info() != Eigen::Success) return {};
  const Eigen::Matrix<double, 12, 1> beta = ldlt.solve(b);
  std::vector<double> sse(static_cast<size_t>(G), 0.0);
  for (size_t k = 0; k < n; ++k) {
    const Vec3 r = y[k] - fx.F[k] * beta.head<9>() - g[k] * beta.tail<3>();
    sse[k * static_cast<size_t>(G) / n] += r.squaredNorm();
  }
  return sse;
}

}  // namespace

LagReport ScanCurrentFieldLag(const ChannelData& ch, const LogInputs& in, double latency_s, const DiagnoseOptions& o) {
  LagReport out;
  const size_t n = ch.t.size();
  const bool usable = in.current != nullptr && !in.current_samples_t.empty() &&
                      in.current_samples_t.size() == in.current_samples_v.size() && ch.current_A.size() == n &&
                      ch.baseline.X.size() == n && ch.y.size() == n && n >= 100;
  if (!usable) return out;
  std::vector<double> t_meas(n);
  for (size_t k = 0; k < n; ++k) t_meas[k] = ch.t[k] - latency_s;
  const std::vector<double> logged = LaggedCurrentAt(in.current_samples_t, in.current_samples_v, t_meas, 0.0);
  const double I_ref = MedianPositive(logged);
  if (!(I_ref >= kMinMedianCurrent_A)) return out;
  FixedNormal fx;
  fx.A.setZero();
  fx.b.setZero();
  fx.F.resize(n);
  for (size_t k = 0; k < n; ++k) {
    fx.F[k] << ch.baseline.X[k], Eigen::Matrix3d::Identity() * ch.current_A[k];
    fx.A.noalias() += fx.F[k].transpose() * fx.F[k];
    fx.b.noalias() += fx.F[k].transpose() * ch.y[k];
  }
  const int G = std::max(4, o.blocks);
  // The lag's physical range (plausibility row current_lag, 0..2 s) in steps of 50 ms, each at the
  // exponent of the physical range (kLagExponentLo..Hi) that fits it best.
  const plausibility::PhysicalRange* range = plausibility::FindRange("current_lag");
  const std::vector<double> grid = realdata::LagGrid(0.0, range != nullptr ? range->hi : 2.0, kFieldLagStep_s);
  std::vector<std::vector<double>> sse;
  for (double tau : grid) {
    const std::vector<double> lagged = LaggedCurrentAt(in.current_samples_t, in.current_samples_v, t_meas, tau);
    std::vector<double> best;
    double best_sum = 0;
    for (double p : kLagExponents) {
      if (p < kLagExponentLo || p > kLagExponentHi) continue;
      std::vector<double> g(n);
      bool finite = true;
      for (size_t k = 0; k < n; ++k) {
        g[k] = I_ref * std::pow(std::max(0.0, lagged[k]) / I_ref, p);
        finite = finite && std::isfinite(g[k]);
      }
      if (!finite) return out;
      std::vector<double> s = BlockSse(fx, ch.y, g, G);
      if (s.empty()) continue;
      double sum = 0;
      for (double v : s) sum += v;
      if (best.empty() || sum < best_sum) {
        best = std::move(s);
        best_sum = sum;
      }
    }
    if (best.empty()) return out;
    sse.push_back(std::move(best));
  }
  const realdata::LagEstimate e = realdata::ProfileLag(grid, sse, o.bootstrap_samples, o.seed);
  if (!e.ok()) return out;
  out.present = true;
  out.value_s = std::max(0.0, e.value_s);
  out.ci95_s = {std::max(0.0, e.ci95_s[0]), e.ci95_s[1]};
  out.against = "current_A";
  out.resolved = e.resolved() && out.ci95_s.lo > 0;
  out.plausible = plausibility::IntervalPlausible("current_lag", out.ci95_s.lo, out.ci95_s.hi);
  return out;
}

}  // namespace hexsim::gap::internal
