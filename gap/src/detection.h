// Detection independent of the candidate library (private to gap/). A gap exists when the held-out
// residual above the nuisance baseline carries structure beyond the noise floor: the held-out mean
// square over the first-difference noise variance (white noise: 1) exceeds 1 + materiality by a
// one-sided test against its spread under white noise (p < 0.01). Whiteness (Ljung–Box) and the
// spectrum describe the structure; they do not decide.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "channels.h"

namespace hexsim::gap::internal {

// High-frequency noise variance per component: mean |e_k − e_{k−1}|² / 6 over close pairs.
double NoiseVariance(const std::vector<double>& t, const std::vector<Vec3>& e);
// Per-component variance of e minus its centred moving average over window_s (coloured floors).
double HighPassVariance(const std::vector<double>& t, const std::vector<Vec3>& e, double window_s);
double MeanSquare(const std::vector<Vec3>& e);
// Where: phase, regime bins and frequency band of the residual.
nlohmann::json Where(const ChannelData& ch, const std::vector<Vec3>& y, const logs::FlightLog& log,
                     const std::vector<std::string>& phases);

struct Structure {
  bool present = false;
  double power_ratio = 0.0;  // held-out mean square / noise floor
  double noise_var = 0.0;
  double p_value = 1.0;      // of "ratio ≤ 1 + materiality"
  double whiteness_p = 1.0;  // Ljung–Box, 20 lags, Bonferroni over axes
};
// r: residual after the baseline; heldout_sse: the baseline's held-out SSE over all CV folds.
Structure DetectStructure(const std::vector<double>& t, const std::vector<Vec3>& r, double heldout_sse, double materiality);
// What is left after the reported model: {share, dominant_freq_Hz, trend, concentrated}.
nlohmann::json ResidualLeft(const std::vector<double>& t, const std::vector<Vec3>& after, double share_left,
                            const nlohmann::json& where_after);

}  // namespace hexsim::gap::internal
