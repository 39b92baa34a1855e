// Detection independent of the candidate library (private to gap/). A gap exists when the held-out
// residual above the nuisance baseline carries structure beyond the noise floor. A real log's floor
// is not white (a 5 Hz current held and interpolated, an attitude logged at 10 Hz: errors that stay
// correlated over a few samples), so its level is not compared with a first-difference variance.
// Structure is what is predictable or what no noise makes:
//   (1) a library-free regressor set (linear functions of the predicted field: any scale,
//       cross-coupling or misalignment; of the current and the throttle) is significant by a
//       cluster-robust Wald test over the time blocks (Hotelling's T², honest when the residual is
//       coloured: blocks are long against its correlation time) and removes more than the
//       materiality share of the noise floor;
//   (2) a spectral line stands above the residual's own smoothed spectrum (a periodic disturbance,
//       a drift: both far above the coloured background around them) and holds more than the
//       materiality share of the noise floor's power.
//   (3) isolated spikes: at least kMinSpikes samples that leave the mean of their two neighbours by
//       more than kSpikeSigma robust standard deviations of that departure (median absolute
//       deviation). No noise makes a 25σ departure; what does in a clean replay are manoeuvre
//       transients of the 10 Hz rows (attitude and current interpolated across a fast change), which
//       reach about 15σ in the selftest's clean logs and 17σ in log171's external compass, and stay
//       below this bound. An intermittent disturbance (a glitching sensor or bus) lands far above it.
// Tests (1) and (2) at alpha/2. The power ratio and Ljung–Box whiteness are reported; they do not
// decide.
#pragma once

#include <string>
#include <vector>

#include "channels.h"

namespace hexsim::gap::internal {

// High-frequency noise variance per component: mean |e_k − e_{k−1}|² / 6 over close pairs.
double NoiseVariance(const std::vector<double>& t, const std::vector<Vec3>& e);
// Per-component variance of e minus its centred moving average over window_s (coloured floors).
double HighPassVariance(const std::vector<double>& t, const std::vector<Vec3>& e, double window_s);
double MeanSquare(const std::vector<Vec3>& e);
// Where: phase, regime bins and frequency band of the residual.
Where Locate(const ChannelData& ch, const std::vector<Vec3>& y, const logs::FlightLog& log,
             const std::vector<std::string>& phases);

inline constexpr double kSpikeSigma = 25.0;
inline constexpr int kMinSpikes = 3;

// The number of isolated spikes in r (see (3) above).
int CountSpikes(const std::vector<Vec3>& r);

struct Structure {
  bool present = false;
  double power_ratio = 0.0;  // held-out mean square / first-difference noise floor (reported)
  double noise_var = 0.0;
  double p_value = 1.0;      // the smaller of the two tests' p-values (Bonferroni over them)
  double whiteness_p = 1.0;  // Ljung–Box, 20 lags, Bonferroni over axes (reported)
  // (1) Library-free regressors: the mean square they remove over the baseline and their
  // cluster-robust Wald p-value.
  double flex_gain_ms = 0.0, flex_p = 1.0;
  // (2) A spectral line above the residual's own (coloured) spectrum: frequency and p-value.
  double line_freq_Hz = 0.0, line_p = 1.0, line_share = 0.0;
  // (3) Isolated spikes: samples that leave both neighbours by more than kSpikeSigma robust σ.
  int spikes = 0;
  std::string found;  // which test(s) found it
};
// r: residual after the baseline; heldout_sse: the baseline's held-out SSE over all CV folds;
// flex_p: cluster-robust Wald p of the library-free set over the baseline (its groups Bonferroni
// corrected); flex_gain_ms: the mean square it removes.
Structure DetectStructure(const std::vector<double>& t, const std::vector<Vec3>& r, double heldout_sse, double materiality,
                          double flex_p, double flex_gain_ms, double alpha);
// What is left after the reported model: share, dominant frequency, trend, spikes, where.
ResidualLeft DescribeLeft(const std::vector<double>& t, const std::vector<Vec3>& after, double share_left,
                          const Where& where_after);

}  // namespace hexsim::gap::internal
