// Discrete Fourier power by FFT (see spectrum.h).
#include "spectrum.h"

#include <complex>
#include <cstddef>
#include <utility>

namespace hexsim::gap::internal {
namespace {

using Complex = std::complex<double>;
constexpr double kPi = 3.141592653589793;

// In-place radix-2 FFT, a.size() a power of two: A_f = Σ_k a_k·e^(∓2πi·f·k/n) (− forward, + inverse,
// the inverse unscaled). Each twiddle from its own cos/sin, so the error does not grow along n.
void Fft(std::vector<Complex>* a, bool inverse) {
  std::vector<Complex>& x = *a;
  const size_t n = x.size();
  for (size_t i = 1, j = 0; i < n; ++i) {
    size_t bit = n >> 1;
    for (; (j & bit) != 0; bit >>= 1) j ^= bit;
    j ^= bit;
    if (i < j) std::swap(x[i], x[j]);
  }
  const double sign = inverse ? 1.0 : -1.0;
  std::vector<Complex> tw(n / 2);
  for (size_t k = 0; k < n / 2; ++k) tw[k] = std::polar(1.0, sign * 2.0 * kPi * static_cast<double>(k) / static_cast<double>(n));
  for (size_t len = 2; len <= n; len <<= 1) {
    const size_t half = len / 2, stride = n / len;
    for (size_t i = 0; i < n; i += len) {
      for (size_t j = 0; j < half; ++j) {
        const Complex u = x[i + j];
        const Complex v = x[i + j + half] * tw[j * stride];
        x[i + j] = u + v;
        x[i + j + half] = u - v;
      }
    }
  }
}

size_t NextPowerOfTwo(size_t n) {
  size_t p = 1;
  while (p < n) p <<= 1;
  return p;
}

}  // namespace

std::vector<double> FourierPower(const std::vector<Vec3>& x) {
  const size_t m = x.size();
  std::vector<double> power;
  if (m < 2) return power;
  power.assign(m / 2, 0.0);
  const bool radix2 = (m & (m - 1)) == 0;
  // Bluestein: f·k = (f² + k² − (f − k)²)/2, so X_f = c_f·Σ_k (x_k·c_k)·conj(c_(f−k)), c_j = e^(−iπ·j²/m):
  // a convolution, done by FFT over N ≥ 2m − 1. The chirp's angle from j² mod 2m (exact integers).
  const size_t N = radix2 ? m : NextPowerOfTwo(2 * m - 1);
  std::vector<Complex> chirp, B;
  if (!radix2) {
    chirp.resize(m);
    for (size_t j = 0; j < m; ++j) {
      const size_t j2 = (j * j) % (2 * m);
      chirp[j] = std::polar(1.0, -kPi * static_cast<double>(j2) / static_cast<double>(m));
    }
    B.assign(N, Complex(0.0, 0.0));
    B[0] = std::conj(chirp[0]);
    for (size_t j = 1; j < m; ++j) B[j] = B[N - j] = std::conj(chirp[j]);
    Fft(&B, false);
  }
  std::vector<Complex> a(N);
  for (int axis = 0; axis < 3; ++axis) {
    std::fill(a.begin(), a.end(), Complex(0.0, 0.0));
    for (size_t k = 0; k < m; ++k) a[k] = radix2 ? Complex(x[k][axis], 0.0) : x[k][axis] * chirp[k];
    Fft(&a, false);
    if (!radix2) {
      for (size_t k = 0; k < N; ++k) a[k] *= B[k];
      Fft(&a, true);
      const double inv_n = 1.0 / static_cast<double>(N);
      for (size_t f = 1; f <= m / 2; ++f) a[f] *= chirp[f] * inv_n;
    }
    for (size_t f = 1; f <= m / 2; ++f) power[f - 1] += std::norm(a[f]);
  }
  return power;
}

}  // namespace hexsim::gap::internal
