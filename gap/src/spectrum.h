// Discrete Fourier power of a three-axis series, by FFT (private to gap/).
#pragma once

#include <vector>

#include "channels.h"

namespace hexsim::gap::internal {

// P_f = Σ_axes |Σ_k x_k·e^(−2πi·f·k/m)|² at the Fourier frequencies f = 1 … m/2 (m = x.size(); entry
// f − 1), x as given (centre it first for a periodogram). Any m: a radix-2 FFT when m is a power of
// two, else Bluestein's chirp-z transform over a power-of-two length ≥ 2m − 1; O(m log m) instead
// of the direct sum's O(m²), equal to it up to rounding. Empty for m < 2.
std::vector<double> FourierPower(const std::vector<Vec3>& x);

}  // namespace hexsim::gap::internal
