#include "hexsim/sim/response.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "hexsim/common/rotation.h"

namespace hexsim::sim {

namespace {

bool PowerOfTwo(int n) { return n > 1 && (n & (n - 1)) == 0; }

// Time at which the linear interpolation of (t, z) first reaches `level`, searching from i0.
double FirstCrossing(const std::vector<double>& t, const std::vector<double>& z, size_t i0, double level) {
  for (size_t i = i0; i < z.size(); ++i) {
    if (z[i] >= level) {
      if (i == i0) return t[i];
      const double f = (level - z[i - 1]) / (z[i] - z[i - 1]);
      return t[i - 1] + f * (t[i] - t[i - 1]);
    }
  }
  return -1.0;
}

// Linear interpolation in log10(f) of the frequency where g (in dB or degrees) passes `level`.
double LogInterp(double f0, double g0, double f1, double g1, double level) {
  const double a = (level - g0) / (g1 - g0);
  return std::pow(10.0, std::log10(f0) + a * (std::log10(f1) - std::log10(f0)));
}

std::vector<double> Unwrap(std::vector<double> phase_rad) {
  for (size_t i = 1; i < phase_rad.size(); ++i) {
    while (phase_rad[i] - phase_rad[i - 1] > kPi) phase_rad[i] -= 2.0 * kPi;
    while (phase_rad[i] - phase_rad[i - 1] < -kPi) phase_rad[i] += 2.0 * kPi;
  }
  return phase_rad;
}

}  // namespace

Result<StepMetrics> AnalyzeStep(const std::vector<double>& t_s, const std::vector<double>& y, double t_step_s,
                                double y_initial, double step_size, const StepOptions& o) {
  if (t_s.size() != y.size() || t_s.size() < 10) return Status::BadInput("step: need ≥ 10 samples of t and y");
  if (!(std::fabs(step_size) > 0)) return Status::BadInput("step: step size must be non-zero");
  size_t i0 = 0;
  while (i0 < t_s.size() && t_s[i0] < t_step_s) ++i0;
  if (t_s.size() - i0 < 10) return Status::BadInput("step: fewer than 10 samples after the step");
  std::vector<double> z(y.size());  // normalised: 0 before, 1 at the target
  for (size_t i = 0; i < y.size(); ++i) z[i] = (y[i] - y_initial) / step_size;

  StepMetrics m;
  m.step_size = step_size;
  const double t10 = FirstCrossing(t_s, z, i0, o.rise_lo_fraction);
  const double t90 = FirstCrossing(t_s, z, i0, o.rise_hi_fraction);
  m.rise_time_s = (t10 >= 0 && t90 >= 0) ? t90 - t10 : -1.0;
  size_t ipk = i0;
  for (size_t i = i0; i < z.size(); ++i) {
    if (z[i] > z[ipk]) ipk = i;
  }
  m.overshoot_fraction = std::max(0.0, z[ipk] - 1.0);
  m.peak_time_s = t_s[ipk] - t_step_s;
  // Settling: after the last sample outside the band (interpolated to the band edge).
  size_t last_out = z.size();
  for (size_t i = z.size(); i-- > i0;) {
    if (std::fabs(z[i] - 1.0) > o.settle_band_fraction) {
      last_out = i;
      break;
    }
  }
  if (last_out == z.size()) {
    m.settling_time_s = 0.0;
  } else if (last_out + 1 < z.size()) {
    const size_t i = last_out;
    const double edge = z[i] > 1.0 ? 1.0 + o.settle_band_fraction : 1.0 - o.settle_band_fraction;
    const double f = (edge - z[i]) / (z[i + 1] - z[i]);
    m.settling_time_s = t_s[i] + f * (t_s[i + 1] - t_s[i]) - t_step_s;
  }
  const size_t n_final = std::max<size_t>(1, static_cast<size_t>(o.final_window_fraction * static_cast<double>(z.size() - i0)));
  double sum = 0.0;
  for (size_t i = y.size() - n_final; i < y.size(); ++i) sum += y[i];
  m.final_value = sum / static_cast<double>(n_final);
  m.steady_state_error = y_initial + step_size - m.final_value;
  return m;
}

Result<Multisine> MakeMultisine(double fs_hz, int n_period, double f_lo_hz, double f_hi_hz, double amplitude,
                                int lines_per_decade) {
  if (!PowerOfTwo(n_period)) return Status::BadInput("multisine: period must be a power of two samples");
  if (!(fs_hz > 0 && f_lo_hz > 0 && f_hi_hz > f_lo_hz && f_hi_hz < fs_hz / 2 && amplitude > 0 && lines_per_decade > 0)) {
    return Status::BadInput("multisine: need 0 < f_lo < f_hi < fs/2 and amplitude > 0");
  }
  Multisine ms;
  ms.fs_hz = fs_hz;
  ms.n_period = n_period;
  const double df = fs_hz / n_period;
  const int k_lo = std::max(1, static_cast<int>(std::ceil(f_lo_hz / df)));
  const int k_hi = static_cast<int>(std::floor(f_hi_hz / df));
  if (k_hi <= k_lo) return Status::BadInput("multisine: band narrower than one frequency line (lengthen the period)");
  const double ratio = std::pow(10.0, 1.0 / lines_per_decade);
  double next = k_lo;
  for (int k = k_lo; k <= k_hi; ++k) {
    if (k + 1e-9 >= next) {
      ms.lines.push_back(k);
      next = std::max(next * ratio, static_cast<double>(k + 1));
    }
  }
  ms.signal.assign(static_cast<size_t>(n_period), 0.0);
  const double K = static_cast<double>(ms.lines.size());
  for (size_t j = 0; j < ms.lines.size(); ++j) {
    const double phase = -kPi * static_cast<double>(j) * static_cast<double>(j + 1) / K;  // Schroeder
    ms.phases_rad.push_back(phase);
    for (int n = 0; n < n_period; ++n) {
      ms.signal[static_cast<size_t>(n)] += std::cos(2.0 * kPi * ms.lines[j] * n / n_period + phase);
    }
  }
  double peak = 0.0;
  for (double v : ms.signal) peak = std::max(peak, std::fabs(v));
  ms.scale = amplitude / peak;
  for (double& v : ms.signal) v *= ms.scale;
  return ms;
}

double Multisine::At(double t_s) const {
  double v = 0.0;
  for (size_t j = 0; j < lines.size(); ++j) v += std::cos(2.0 * kPi * lines[j] * fs_hz / n_period * t_s + phases_rad[j]);
  return scale * v;
}

double LogChirp(double t_s, double f0_hz, double f1_hz, double duration_s, double amplitude) {
  const double k = std::log(f1_hz / f0_hz) / duration_s;
  // phase = 2π f0 (e^{kt} − 1)/k
  return amplitude * std::sin(2.0 * kPi * f0_hz * (std::exp(k * t_s) - 1.0) / k);
}

void Fft(std::vector<std::complex<double>>* xp) {
  auto& x = *xp;
  const size_t n = x.size();
  for (size_t i = 1, j = 0; i < n; ++i) {  // bit reversal
    size_t bit = n >> 1;
    for (; j & bit; bit >>= 1) j ^= bit;
    j ^= bit;
    if (i < j) std::swap(x[i], x[j]);
  }
  for (size_t len = 2; len <= n; len <<= 1) {
    const double ang = -2.0 * kPi / static_cast<double>(len);
    const std::complex<double> wl(std::cos(ang), std::sin(ang));
    for (size_t i = 0; i < n; i += len) {
      std::complex<double> w(1.0, 0.0);
      for (size_t j = 0; j < len / 2; ++j) {
        const std::complex<double> a = x[i + j], b = x[i + j + len / 2] * w;
        x[i + j] = a + b;
        x[i + j + len / 2] = a - b;
        w *= wl;
      }
    }
  }
}

double FrequencyResponse::GainDb(size_t i) const { return 20.0 * std::log10(std::abs(H[i])); }
double FrequencyResponse::PhaseDeg(size_t i) const {
  std::vector<double> p(H.size());
  for (size_t j = 0; j < H.size(); ++j) p[j] = std::arg(H[j]);
  return Unwrap(p)[i] * 180.0 / kPi;
}

Result<FrequencyResponse> EstimateFrequencyResponse(const std::vector<double>& u, const std::vector<double>& y,
                                                    double fs_hz, const WelchOptions& o,
                                                    const std::vector<int>& bins) {
  const int L = o.segment;
  if (!PowerOfTwo(L)) return Status::BadInput("freqresp: segment must be a power of two");
  if (o.overlap < 0 || o.overlap >= L) return Status::BadInput("freqresp: overlap must be in [0, segment)");
  if (u.size() != y.size() || u.size() < static_cast<size_t>(L)) {
    return Status::BadInput(fmt::format("freqresp: need equal-length signals of at least {} samples", L));
  }
  std::vector<double> w(static_cast<size_t>(L), 1.0);
  if (o.window == Window::kHann) {
    for (int n = 0; n < L; ++n) w[static_cast<size_t>(n)] = 0.5 - 0.5 * std::cos(2.0 * kPi * n / L);
  }
  const size_t half = static_cast<size_t>(L / 2);
  std::vector<double> Suu(half + 1, 0.0), Syy(half + 1, 0.0);
  std::vector<std::complex<double>> Suy(half + 1, 0.0), U(static_cast<size_t>(L)), Y(static_cast<size_t>(L));
  FrequencyResponse fr;
  const size_t hop = static_cast<size_t>(L - o.overlap);
  for (size_t s0 = 0; s0 + static_cast<size_t>(L) <= u.size(); s0 += hop) {
    double mu = 0.0, my = 0.0;
    if (o.detrend) {
      for (size_t n = 0; n < static_cast<size_t>(L); ++n) {
        mu += u[s0 + n];
        my += y[s0 + n];
      }
      mu /= L;
      my /= L;
    }
    for (size_t n = 0; n < static_cast<size_t>(L); ++n) {
      U[n] = w[n] * (u[s0 + n] - mu);
      Y[n] = w[n] * (y[s0 + n] - my);
    }
    Fft(&U);
    Fft(&Y);
    for (size_t k = 0; k <= half; ++k) {
      Suu[k] += std::norm(U[k]);
      Syy[k] += std::norm(Y[k]);
      Suy[k] += std::conj(U[k]) * Y[k];
    }
    ++fr.segments;
  }
  std::vector<int> use = bins;
  if (use.empty()) {
    for (int k = 1; k <= L / 2; ++k) use.push_back(k);
  }
  for (int k : use) {
    if (k < 1 || k > L / 2) return Status::BadInput(fmt::format("freqresp: bin {} outside 1..{}", k, L / 2));
    const size_t i = static_cast<size_t>(k);
    if (!(Suu[i] > 0)) continue;
    fr.f_hz.push_back(k * fs_hz / L);
    fr.H.push_back(Suy[i] / Suu[i]);
    fr.coherence.push_back(Syy[i] > 0 ? std::norm(Suy[i]) / (Suu[i] * Syy[i]) : 0.0);
  }
  if (fr.f_hz.empty()) return Status::BadInput("freqresp: the input has no power in the analysed band");
  return fr;
}

LoopMetrics AnalyzeClosedLoop(const FrequencyResponse& T, double min_coherence) {
  LoopMetrics m;
  std::vector<double> f, gdb, lg_db, lph;
  std::vector<std::complex<double>> Lc;
  m.min_coherence = 1.0;
  for (size_t i = 0; i < T.f_hz.size(); ++i) {
    if (T.coherence[i] < min_coherence) continue;
    f.push_back(T.f_hz[i]);
    gdb.push_back(20.0 * std::log10(std::abs(T.H[i])));
    const std::complex<double> L = T.H[i] / (1.0 - T.H[i]);
    lg_db.push_back(20.0 * std::log10(std::abs(L)));
    lph.push_back(std::arg(L));
    m.min_coherence = std::min(m.min_coherence, T.coherence[i]);
  }
  if (f.empty()) {
    m.min_coherence = 0.0;
    return m;
  }
  lph = Unwrap(lph);
  // Keep the phase branch that starts in (−360°, 0°] (a loop with integral action starts near −90°).
  while (lph[0] > 0) {
    for (double& p : lph) p -= 2.0 * kPi;
  }
  m.low_frequency_gain_db = gdb[0];
  m.peak_gain_db = *std::max_element(gdb.begin(), gdb.end());
  for (size_t i = 1; i < f.size(); ++i) {
    const double level = -3.0;  // a tracking loop's DC gain is 1 (0 dB)
    if (gdb[i] < level && gdb[i - 1] >= level) {
      m.bandwidth_hz = LogInterp(f[i - 1], gdb[i - 1], f[i], gdb[i], level);
      break;
    }
  }
  for (size_t i = 1; i < f.size(); ++i) {
    if (lg_db[i - 1] >= 0.0 && lg_db[i] < 0.0) {
      m.gain_crossover_hz = LogInterp(f[i - 1], lg_db[i - 1], f[i], lg_db[i], 0.0);
      const double a = (0.0 - lg_db[i - 1]) / (lg_db[i] - lg_db[i - 1]);
      m.phase_margin_deg = 180.0 + (lph[i - 1] + a * (lph[i] - lph[i - 1])) * 180.0 / kPi;
      break;
    }
  }
  m.gain_margin_db = std::numeric_limits<double>::infinity();
  for (size_t i = 1; i < f.size(); ++i) {
    if (lph[i - 1] >= -kPi && lph[i] < -kPi) {
      m.phase_crossover_hz = LogInterp(f[i - 1], lph[i - 1], f[i], lph[i], -kPi);
      const double a = (-kPi - lph[i - 1]) / (lph[i] - lph[i - 1]);
      m.gain_margin_db = -(lg_db[i - 1] + a * (lg_db[i] - lg_db[i - 1]));
      break;
    }
  }
  return m;
}

}  // namespace hexsim::sim
