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

  uint64_t NextU64();
  // Uniform in [0, 1).
  double Uniform();
  // Standard normal (polar Box-Muller, cached second value).
  double Normal();
  double Normal(double mean, double std) { return mean + std * Normal(); }
  Eigen::Vector3d Normal3(double std) { return {std * Normal(), std * Normal(), std * Normal()}; }

 private:
  uint64_t s_[4] = {0, 0, 0, 0};
  bool has_spare_ = false;
  double spare_ = 0.0;
};

// FNV-1a hash of a string, used to derive stream seeds.
uint64_t HashName(std::string_view name);

}  // namespace hexsim
