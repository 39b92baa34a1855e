// current_lag's free member (channels.h, AddLaggedCurrentField): a field the vehicle file does not
// model that follows the current through a first-order lag τ and grows as a power p of it (eddy
// currents in a frame plate, a slow current sensor, a soft-iron part magnetised by the current's own
// field). The configured-wiring member (replay_compass.cc) lags only the field the vehicle file
// models; this one has a free direction, so a withheld lagged field is described too.
#include <algorithm>
#include <cmath>
#include <vector>

#include "channels.h"
#include "replay_util.h"

namespace hexsim::gap::internal {
namespace {

// Below this flight median current there is no current-driven field to lag (a power monitor that
// reads nothing, or motors idle): 0.5 A is the least a single motor draws carrying any weight.
constexpr double kMinMedianCurrent_A = 0.5;

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

}  // namespace hexsim::gap::internal
