#include "hexsim/magnetics/ellipsoid_fit.h"

#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "hexsim/common/rng.h"
#include "support/calib_synth.h"

namespace hexsim::magnetics {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

constexpr double kField_uT = 50.0;
constexpr int kParams = 9;

// Uniform random directions, H = K·(F·u) + β + noise.
std::vector<Vector3d> SphereSamples(const Matrix3d& K, const Vector3d& beta, double sigma_uT, int n, uint64_t seed) {
  RngStream rng(seed, "ellipsoid_test");
  std::vector<Vector3d> H;
  for (int i = 0; i < n; ++i) {
    Vector3d u = rng.Normal3(1.0);
    u.normalize();
    H.emplace_back(K * (kField_uT * u) + beta + rng.Normal3(sigma_uT));
  }
  return H;
}

// Per-parameter standard error of a least-squares fit: σ·√(p/N) (β in µT; K relative, /F).
double StdErr(double sigma_uT, int n) { return sigma_uT * std::sqrt(static_cast<double>(kParams) / n); }

TEST(EllipsoidFit, GivenFullSphereSamplesWithNoise_WhenFitted_ThenRecoversSoftAndHardIronWithinNoiseTolerance) {
  const Matrix3d K = testing::TestSoftIron();
  const Vector3d beta(14.0, -9.0, 25.0);
  const double sigma = 0.3;
  const int n = 600;
  const auto H = SphereSamples(K, beta, sigma, n, 1);
  const EllipsoidFit f = FitEllipsoid(H, EllipsoidFitOptions{});
  ASSERT_TRUE(f.status.ok()) << f.status.message();
  EXPECT_TRUE(f.converged);
  const double tol_beta = 5.0 * StdErr(sigma, n);
  const double tol_K = 5.0 * StdErr(sigma, n) / kField_uT;
  EXPECT_LT((f.hard_iron_uT - beta).cwiseAbs().maxCoeff(), tol_beta);
  EXPECT_LT((f.soft_iron - K).cwiseAbs().maxCoeff(), tol_K);
  EXPECT_NEAR(f.radius_uT, kField_uT, tol_beta);
  EXPECT_NEAR(f.soft_iron.determinant(), 1.0, 1e-9);
  // The geometric residual of a correct fit is the noise itself.
  EXPECT_NEAR(f.rms_residual_uT, sigma, 0.15 * sigma);
  EXPECT_TRUE(f.gate.accepted) << f.gate.Failures();
  EXPECT_GT(f.coverage_fraction, 0.9);
}

TEST(EllipsoidFit, GivenThreeTurntablePlanesWithNoise_WhenFitted_ThenRecoversSoftAndHardIron) {
  testing::SynthRig rig;
  rig.soft_iron = testing::TestSoftIron();
  rig.controls_u = {0.0};
  rig.noise_uT = 0.1;
  RngStream rng(7, "turntable");
  const auto samples = testing::Turntable(rig, rng);
  std::vector<Vector3d> H;
  H.reserve(samples.size());
  for (const auto& s : samples) H.push_back(s.mag_B_uT);
  EllipsoidFitOptions o;
  o.planes_present = 3;
  const EllipsoidFit f = FitEllipsoid(H, o);
  ASSERT_TRUE(f.status.ok()) << f.status.message();
  const int n = static_cast<int>(H.size());
  const double F = rig.earth_N_uT.norm();
  // Three circles constrain the quadric less evenly than a full sphere: geometry factor 3.
  const double tol_beta = 3.0 * 5.0 * StdErr(rig.noise_uT, n);
  const double tol_K = 3.0 * 5.0 * StdErr(rig.noise_uT, n) / F;
  EXPECT_LT((f.hard_iron_uT - rig.hard_iron0_uT).cwiseAbs().maxCoeff(), tol_beta);
  EXPECT_LT((f.soft_iron - rig.soft_iron).cwiseAbs().maxCoeff(), tol_K);
  EXPECT_NEAR(f.radius_uT, F, tol_beta);
  EXPECT_TRUE(f.gate.accepted) << f.gate.Failures();
  // Three circles are not a full sphere: coverage passes by the rig's planes.
  const GateCriterion* cov = f.gate.Find("coverage");
  ASSERT_NE(cov, nullptr);
  EXPECT_TRUE(cov->pass);
}

TEST(EllipsoidFit, GivenSamplesFromOnePlane_WhenFitted_ThenBadInputNamingThePlane) {
  testing::SynthRig rig;
  rig.planes = {"xy"};
  rig.controls_u = {0.0};
  RngStream rng(3, "planar");
  std::vector<Vector3d> H;
  for (const auto& s : testing::Turntable(rig, rng)) H.push_back(s.mag_B_uT);
  // Exactly planar: remove the noise on z.
  for (auto& h : H) h.z() = rig.hard_iron0_uT.z() + rig.earth_N_uT.z();
  const EllipsoidFit f = FitEllipsoid(H, EllipsoidFitOptions{});
  EXPECT_EQ(f.status.code(), StatusCode::kBadInput);
  EXPECT_NE(f.status.message().find("plane"), std::string::npos) << f.status.message();
  EXPECT_EQ(FitSphere(H, EllipsoidFitOptions{}).status.code(), StatusCode::kBadInput);
}

TEST(EllipsoidFit, GivenFewerThanTenSamples_WhenFitted_ThenBadInput) {
  const auto H = SphereSamples(Matrix3d::Identity(), Vector3d::Zero(), 0.1, 9, 2);
  const EllipsoidFit f = FitEllipsoid(H, EllipsoidFitOptions{});
  EXPECT_EQ(f.status.code(), StatusCode::kBadInput);
  EXPECT_NE(f.status.message().find("too few"), std::string::npos);
}

TEST(EllipsoidFit, GivenANanSample_WhenFitted_ThenBadInputNamingTheSample) {
  auto H = SphereSamples(Matrix3d::Identity(), Vector3d::Zero(), 0.1, 50, 3);
  H[17].y() = std::numeric_limits<double>::quiet_NaN();
  const EllipsoidFit f = FitEllipsoid(H, EllipsoidFitOptions{});
  EXPECT_EQ(f.status.code(), StatusCode::kBadInput);
  EXPECT_NE(f.status.message().find("17"), std::string::npos);
}

TEST(EllipsoidFit, GivenAFieldStrengthAboveTheRadiusBound_WhenFitted_ThenGateRejectsNamingRadiusMax) {
  const auto H = SphereSamples(testing::TestSoftIron(), Vector3d(3, 4, 5), 0.2, 300, 4);
  EllipsoidFitOptions o;
  o.max_radius_uT = 40.0;  // the data's field is 50 µT
  const EllipsoidFit f = FitEllipsoid(H, o);
  ASSERT_TRUE(f.status.ok());
  EXPECT_FALSE(f.gate.accepted);
  const GateCriterion* r = f.gate.Find("radius_uT");
  ASSERT_NE(r, nullptr);
  EXPECT_FALSE(r->pass);
  EXPECT_EQ(r->failed_bound, "max");
  EXPECT_NE(f.gate.Failures().find("radius_uT"), std::string::npos);
  // Every other criterion passes: the gate names only what failed.
  for (const auto& c : f.gate.criteria) {
    if (c.name != "radius_uT") {
      EXPECT_TRUE(c.pass) << c.name;
    }
  }
}

TEST(EllipsoidFit, GivenStrongSoftIron_WhenFitted_ThenGateNamesTheDiagonalBound) {
  Matrix3d S = Vector3d(1.5, 0.8, 0.85).asDiagonal();
  S /= std::cbrt(S.determinant());
  const EllipsoidFit f = FitEllipsoid(SphereSamples(S, Vector3d::Zero(), 0.1, 300, 5), EllipsoidFitOptions{});
  ASSERT_TRUE(f.status.ok());
  const GateCriterion* dx = f.gate.Find("soft_iron_diag_x");
  ASSERT_NE(dx, nullptr);
  EXPECT_EQ(dx->failed_bound, "max");
  EXPECT_FALSE(f.gate.accepted);
}

TEST(EllipsoidFit, GivenInvalidOptions_WhenValidated_ThenBadInput) {
  EllipsoidFitOptions o;
  o.min_radius_uT = 80.0;
  o.max_radius_uT = 20.0;
  EXPECT_EQ(o.IsValid().code(), StatusCode::kBadInput);
  EXPECT_EQ(FitEllipsoid(SphereSamples(Matrix3d::Identity(), Vector3d::Zero(), 0.1, 50, 6), o).status.code(),
            StatusCode::kBadInput);
}

TEST(EllipsoidFit, GivenHardIronOnly_WhenSphereFitted_ThenRecoversCentreAndRadius) {
  const Vector3d beta(-20.0, 8.0, 3.0);
  const double sigma = 0.3;
  const int n = 400;
  const EllipsoidFit f = FitSphere(SphereSamples(Matrix3d::Identity(), beta, sigma, n, 8), EllipsoidFitOptions{});
  ASSERT_TRUE(f.status.ok()) << f.status.message();
  const double tol = 5.0 * sigma * std::sqrt(4.0 / n);
  EXPECT_LT((f.hard_iron_uT - beta).cwiseAbs().maxCoeff(), tol);
  EXPECT_NEAR(f.radius_uT, kField_uT, tol);
  EXPECT_TRUE(f.soft_iron.isIdentity());
}

}  // namespace
}  // namespace hexsim::magnetics
