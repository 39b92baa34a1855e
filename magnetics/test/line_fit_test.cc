#include "hexsim/magnetics/line_fit.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "hexsim/common/rng.h"

namespace hexsim::magnetics {
namespace {

using Eigen::Vector3d;

std::vector<Vector3d> PointsOnLine(const Vector3d& p0, const Vector3d& dir, const std::vector<double>& t) {
  std::vector<Vector3d> pts;
  pts.reserve(t.size());
  for (double ti : t) pts.emplace_back(p0 + ti * dir);
  return pts;
}

double Median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

TEST(LineFit, GivenNoiselessPoints_WhenFittedByPaperTlsAndSvd_ThenBothGiveTheSameLine) {
  const Vector3d p0(10.0, -4.0, 20.0), dir = Vector3d(2.0, -1.5, 3.0).normalized();
  const auto pts = PointsOnLine(p0, dir, {0.0, 1.0, 2.5, 4.0, 7.0});
  const PaperLineFit paper = FitLinePaperTls(pts, LineFitOptions{});
  const SvdLineFit svd = FitLineSvd(pts);
  ASSERT_TRUE(paper.status.ok()) << paper.status.message();
  ASSERT_TRUE(svd.status.ok());
  EXPECT_TRUE(paper.converged);
  EXPECT_NEAR(std::abs(paper.line.direction.dot(svd.line.direction)), 1.0, 1e-12);
  // x = a z + b, y = c z + d with a = dx/dz, c = dy/dz.
  EXPECT_NEAR(paper.a, dir.x() / dir.z(), 1e-9);
  EXPECT_NEAR(paper.c, dir.y() / dir.z(), 1e-9);
  for (const auto& p : pts) {
    EXPECT_LT(paper.line.DistanceTo(p), 1e-9);
    EXPECT_LT(svd.line.DistanceTo(p), 1e-9);
  }
  EXPECT_LT(paper.rms_residual_uT, 1e-9);
}

// Errors in all coordinates: OLS of x on z is attenuated by var(z)/(var(z) + σ²); TLS is not.
TEST(LineFit, GivenNoiseInEveryCoordinate_WhenFittedOverManySeeds_ThenTlsSlopeIsLessBiasedThanOls) {
  const double a_true = 0.9, c_true = -0.6, sigma = 1.0;
  const Vector3d p0(5.0, 3.0, 0.0);
  const Vector3d dir(a_true, c_true, 1.0);
  std::vector<double> t;
  t.reserve(12);
  for (int i = 0; i < 12; ++i) t.push_back(-4.0 + 8.0 * i / 11.0);
  double var_z = 0.0;
  for (double ti : t) var_z += ti * ti / t.size();
  std::vector<double> ols, paper, svd;
  for (uint64_t seed = 0; seed < 300; ++seed) {
    RngStream rng(seed, "tls_bias");
    auto pts = PointsOnLine(p0, dir, t);
    for (auto& p : pts) p += rng.Normal3(sigma);
    double mz = 0, mx = 0;
    for (const auto& p : pts) {
      mz += p.z() / pts.size();
      mx += p.x() / pts.size();
    }
    double szz = 0, sxz = 0;
    for (const auto& p : pts) {
      szz += (p.z() - mz) * (p.z() - mz);
      sxz += (p.x() - mx) * (p.z() - mz);
    }
    ols.push_back(sxz / szz);
    const PaperLineFit pf = FitLinePaperTls(pts, LineFitOptions{});
    ASSERT_TRUE(pf.status.ok()) << pf.status.message() << " seed " << seed;
    paper.push_back(pf.a);
    const SvdLineFit sf = FitLineSvd(pts);
    svd.push_back(sf.line.direction.x() / sf.line.direction.z());
  }
  const double bias_ols = Median(ols) - a_true;
  const double bias_paper = Median(paper) - a_true;
  const double bias_svd = Median(svd) - a_true;
  // The setup must show the attenuation it tests against: at least half the theoretical bias.
  const double bias_theory = -a_true * sigma * sigma / (var_z + sigma * sigma);
  EXPECT_LT(bias_ols, 0.5 * bias_theory) << "ols " << bias_ols << " theory " << bias_theory << " paper " << bias_paper << " svd " << bias_svd;
  EXPECT_LT(std::abs(bias_paper), std::abs(bias_ols));
  EXPECT_LT(std::abs(bias_svd), std::abs(bias_ols));
}

TEST(LineFit, GivenCentresMovingInTheXYPlane_WhenFitted_ThenPaperFormIsSingularAndSvdStillWorks) {
  const Vector3d p0(10.0, -4.0, 20.0), dir = Vector3d(1.0, 2.0, 0.0).normalized();
  const auto pts = PointsOnLine(p0, dir, {0.0, 2.0, 3.0, 5.0});
  const PaperLineFit paper = FitLinePaperTls(pts, LineFitOptions{});
  EXPECT_EQ(paper.status.code(), StatusCode::kNumerical);
  EXPECT_NE(paper.status.message().find("singular"), std::string::npos) << paper.status.message();
  const SvdLineFit svd = FitLineSvd(pts);
  ASSERT_TRUE(svd.status.ok());
  EXPECT_NEAR(std::abs(svd.line.direction.dot(dir)), 1.0, 1e-12);
  EXPECT_LT(svd.rms_residual_uT, 1e-12);
}

TEST(LineFit, GivenOnePointOrNan_WhenFitted_ThenBadInput) {
  EXPECT_EQ(FitLineSvd({Vector3d(1, 2, 3)}).status.code(), StatusCode::kBadInput);
  EXPECT_EQ(FitLineSvd({Vector3d(1, 2, 3), Vector3d(NAN, 0, 0)}).status.code(), StatusCode::kBadInput);
  EXPECT_EQ(FitLinePaperTls({Vector3d(1, 2, 3)}, LineFitOptions{}).status.code(), StatusCode::kBadInput);
}

TEST(AlongFit, GivenPositionsLinearInCurrent_WhenLinearFitted_ThenRecoversInterceptAndSlope) {
  const std::vector<double> I = {0.6, 35.6, 53.1, 20.0};
  std::vector<double> s;
  s.reserve(I.size());
  for (double i : I) s.push_back(-2.0 + 0.11 * i);
  const AlongFit f = FitLinearAlong(I, s);
  ASSERT_TRUE(f.status.ok());
  EXPECT_NEAR(f.model.s0_uT, -2.0, 1e-12);
  EXPECT_NEAR(f.model.k_uT_per_x, 0.11, 1e-12);
  EXPECT_NEAR(f.model.Eval(100.0), -2.0 + 11.0, 1e-10);
}

TEST(AlongFit, GivenOneDistinctIndex_WhenFitted_ThenBadInput) {
  EXPECT_EQ(FitLinearAlong({200, 200}, {1, 2}).status.code(), StatusCode::kBadInput);
  EXPECT_EQ(FitMonotoneAlong({200, 200}, {1, 2}).status.code(), StatusCode::kBadInput);
}

TEST(AlongFit, GivenMonotoneKnots_WhenMonotoneFitted_ThenInterpolatesThemAndStaysMonotoneBetween) {
  const std::vector<double> u = {0, 100, 200, 300, 500};
  const std::vector<double> s = {0.0, 0.5, 2.5, 3.0, 6.0};
  const AlongFit f = FitMonotoneAlong(u, s);
  ASSERT_TRUE(f.status.ok());
  for (size_t i = 0; i < u.size(); ++i) EXPECT_NEAR(f.model.Eval(u[i]), s[i], 1e-12);
  double prev = f.model.Eval(-50.0);
  for (double x = -49.0; x <= 600.0; x += 1.0) {
    const double v = f.model.Eval(x);
    EXPECT_GE(v, prev - 1e-12) << "at x = " << x;
    prev = v;
  }
}

TEST(AlongFit, GivenANonMonotoneNoisyPoint_WhenMonotoneFitted_ThenTheModelIsStillMonotone) {
  // Decreasing trend with one violation: pool-adjacent-violators merges the pair.
  const std::vector<double> u = {0, 100, 200, 300};
  const std::vector<double> s = {0.0, -2.0, -1.8, -5.0};
  const AlongFit f = FitMonotoneAlong(u, s);
  ASSERT_TRUE(f.status.ok());
  EXPECT_NEAR(f.model.Eval(100), -1.9, 1e-12);
  EXPECT_NEAR(f.model.Eval(200), -1.9, 1e-12);
  double prev = f.model.Eval(0.0);
  for (double x = 1.0; x <= 300.0; x += 1.0) {
    const double v = f.model.Eval(x);
    EXPECT_LE(v, prev + 1e-12);
    prev = v;
  }
}

TEST(HardIronLine, GivenALineAndALinearAlongModel_WhenEvaluated_ThenReturnsThePointAtThatPosition) {
  HardIronLine h;
  h.line.point_uT = Vector3d(1, 2, 3);
  h.line.direction = Vector3d(0, 0.6, 0.8);
  h.along.kind = AlongKind::kLinear;
  h.along.s0_uT = 1.0;
  h.along.k_uT_per_x = 0.01;
  EXPECT_TRUE(h.At(300.0).isApprox(Vector3d(1, 2 + 0.6 * 4.0, 3 + 0.8 * 4.0), 1e-12));
}

}  // namespace
}  // namespace hexsim::magnetics
