// Seeded, independent random streams. No hidden global state: every stream is derived from a run
// seed and a stream name, so adding a sensor never changes another sensor's noise.
#pragma once

#include <cstdint>
#include <string_view>

#include <Eigen/Core>

namespace hexsim {

// SplitMix64-seeded xoshiro256** generator with its own Gaussian sampler, so the numbers do not
// depend on the standard library's distribution implementation.
class RngStream {
 public:
  RngStream() : RngStream(0, "default") {}
  RngStream(uint64_t seed, std::string_view name);

  // Inline: the sensors draw ~30 of these a physics step.
  uint64_t NextU64() {
    const uint64_t result = Rotl(s_[1] * 5, 7) * 9;
    const uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = Rotl(s_[3], 45);
    return result;
  }
  // Uniform in [0, 1).
  double Uniform() { return static_cast<double>(NextU64() >> 11) * 0x1.0p-53; }
  // Standard normal (polar Box-Muller, cached second value).
  double Normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    return NormalPair();
  }
  double Normal(double mean, double std) { return mean + std * Normal(); }
  Eigen::Vector3d Normal3(double std) { return {std * Normal(), std * Normal(), std * Normal()}; }

 private:
  static uint64_t Rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  // Draws a pair: returns one, keeps the other as the spare.
  double NormalPair();

  uint64_t s_[4] = {0, 0, 0, 0};
  bool has_spare_ = false;
  double spare_ = 0.0;
};

// FNV-1a hash of a string, used to derive stream seeds.
uint64_t HashName(std::string_view name);

}  // namespace hexsim
