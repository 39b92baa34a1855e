// Calibration fits: the 300-sample ellipsoid fit and the TLS line fits of the ellipsoid centres.
#include <benchmark/benchmark.h>

#include <cmath>

#include "hexsim/common/rng.h"
#include "hexsim/magnetics/ellipsoid_fit.h"
#include "hexsim/magnetics/line_fit.h"

namespace {

using Eigen::Vector3d;

// Samples H = K·h + β of a 50 µT field over the sphere of directions, with 0.3 µT noise.
std::vector<Vector3d> EllipsoidSamples(int n) {
  hexsim::RngStream rng(1, "bench.ellipsoid");
  Eigen::Matrix3d K;
  K << 1.05, 0.03, -0.02, 0.03, 0.96, 0.01, -0.02, 0.01, 1.0;
  const Vector3d beta(12.0, -7.0, 25.0);
  std::vector<Vector3d> out;
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / n;  // Fibonacci sphere
    const double phi = i * 2.399963229728653;
    const Vector3d u(std::sqrt(1 - z * z) * std::cos(phi), std::sqrt(1 - z * z) * std::sin(phi), z);
    out.emplace_back(K * (50.0 * u) + beta + rng.Normal3(0.3));
  }
  return out;
}

// Ellipsoid centres along a line (the adaptive method's hard iron moving with current).
std::vector<Vector3d> LinePoints(int n) {
  hexsim::RngStream rng(2, "bench.line");
  const Vector3d p0(10, -5, 20), dir = Vector3d(0.3, -0.5, 0.8).normalized();
  std::vector<Vector3d> out;
  out.reserve(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) out.emplace_back(p0 + (3.0 * i) * dir + rng.Normal3(0.2));
  return out;
}

void BM_EllipsoidFit300(benchmark::State& state) {
  const auto samples = EllipsoidSamples(300);
  hexsim::magnetics::EllipsoidFitOptions opt;
  for (auto _ : state) {
    auto fit = hexsim::magnetics::FitEllipsoid(samples, opt);
    benchmark::DoNotOptimize(fit.hard_iron_uT);
  }
  auto fit = hexsim::magnetics::FitEllipsoid(samples, opt);
  state.counters["iterations"] = fit.iterations;
}
BENCHMARK(BM_EllipsoidFit300)->Unit(benchmark::kMicrosecond);

void BM_LineFitSvd(benchmark::State& state) {
  const auto pts = LinePoints(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    auto fit = hexsim::magnetics::FitLineSvd(pts);
    benchmark::DoNotOptimize(fit.line.direction);
  }
}
BENCHMARK(BM_LineFitSvd)->Arg(4)->Arg(10)->Arg(100)->Unit(benchmark::kMicrosecond);

void BM_LineFitPaperTls(benchmark::State& state) {
  const auto pts = LinePoints(static_cast<int>(state.range(0)));
  hexsim::magnetics::LineFitOptions opt;
  for (auto _ : state) {
    auto fit = hexsim::magnetics::FitLinePaperTls(pts, opt);
    benchmark::DoNotOptimize(fit.a);
  }
}
BENCHMARK(BM_LineFitPaperTls)->Arg(4)->Arg(10)->Arg(100)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
