// Free-hand compass calibration on dumps generated here, with known offset b and A:
// raw = A⁻¹·B + b + noise, B = F·u over the attitudes each case describes.
#include "hexsim/magnetics/field_calibration.h"

#include <cmath>
#include <set>
#include <vector>

#include <Eigen/LU>
#include <gtest/gtest.h>

#include "hexsim/common/rng.h"
#include "hexsim/magnetics/autopilot_params.h"
#include "hexsim/magnetics/calibrate.h"
#include "support/calib_synth.h"

namespace hexsim::magnetics {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

constexpr double kF_uT = 50.0;
const Vector3d kOffset_uT(14.0, -9.0, 25.0);

Matrix3d TrueK() { return testing::TestSoftIron(); }

// Directions: `kind` "sphere" (uniform), "flat" (a level spin: body z never tilts), "little"
// (within ~5° of one attitude).
std::vector<Vector3d> Dump(const std::string& kind, int n, double sigma_uT, uint64_t seed, const Matrix3d& K = TrueK(),
                           const Vector3d& b = kOffset_uT) {
  RngStream rng(seed, "field_calibration_test");
  const Vector3d earth_N(20.0, 0.0, std::sqrt(kF_uT * kF_uT - 400.0));
  std::vector<Vector3d> H;
  for (int i = 0; i < n; ++i) {
    Vector3d B;
    if (kind == "sphere") {
      B = rng.Normal3(1.0).normalized() * kF_uT;
    } else if (kind == "flat") {
      const double yaw = 2.0 * M_PI * i / n;
      B = Eigen::AngleAxisd(-yaw, Vector3d::UnitZ()) * earth_N;
    } else {
      const double angle = 0.08 * rng.Normal();  // draws in a fixed order (arguments are unsequenced)
      B = Eigen::AngleAxisd(angle, rng.Normal3(1.0).normalized()) * earth_N;
    }
    H.emplace_back(K * B + b + rng.Normal3(sigma_uT));
  }
  return H;
}

FieldCalibrationOptions Method(const std::string& m) {
  FieldCalibrationOptions o;
  o.method = m;
  return o;
}

TEST(FieldCalibration, GivenFullSphere_WhenAuto_ThenEllipsoidRecoversOffsetAndShape) {
  const auto H = Dump("sphere", 600, 0.05, 1);
  auto c = CalibrateField(H, Method("auto"));
  ASSERT_TRUE(c.ok()) << c.status().message();
  EXPECT_EQ(c->method_used, "ellipsoid");
  EXPECT_LT((c->offset_uT - kOffset_uT).norm(), 0.03);
  // det A = 1 without a field norm: A is K⁻¹ itself (the reference-fit tolerance: shape within 0.001).
  EXPECT_LT((c->A - TrueK().inverse()).cwiseAbs().maxCoeff(), 0.001);
  EXPECT_NEAR(c->radius_uT, kF_uT, 0.05);
  EXPECT_LT(c->norm_spread_after, 0.002);
  EXPECT_GT(c->norm_spread_before, 0.03);
  EXPECT_GT(c->coverage.eigenvalues(0), 0.1);
  EXPECT_TRUE(c->accepted);
  EXPECT_TRUE(c->warnings.empty());
}

TEST(FieldCalibration, GivenAHardIronLargerThanTheField_WhenAuto_ThenCoverageIsJudgedOnTheFieldNotTheOffset) {
  // Directions in a belt |u_z| <= 0.5 (the z axis spread is a quarter of the others, still enough
  // for an ellipsoid), |B| = 50 uT, hard iron 57 uT: scaled by the raw norm (~76 uT) the smallest
  // eigenvalue would be ~0.036, below the ellipsoid's 0.05; about the field it is ~0.083.
  const Vector3d b(40.0, 35.0, -20.0);
  std::vector<Vector3d> H;
  const int n = 400;
  for (int i = 0; i < n; ++i) {
    const double z = 0.5 * (1.0 - (2.0 * i + 1.0) / n), rho = std::sqrt(1.0 - z * z), phi = 2.39996322972865332 * i;
    H.emplace_back(TrueK() * Vector3d(kF_uT * rho * std::cos(phi), kF_uT * rho * std::sin(phi), kF_uT * z) + b);
  }
  auto c = CalibrateField(H, Method("auto"));
  ASSERT_TRUE(c.ok()) << c.status().message();
  EXPECT_EQ(c->method_used, "ellipsoid") << c->why;
  EXPECT_NEAR(c->coverage.eigenvalues(0), 1.0 / 12.0, 0.02);
  EXPECT_LT((c->offset_uT - b).norm(), 0.05);
}

TEST(FieldCalibration, GivenFieldNorm_WhenFitted_ThenAMapsToThatNorm) {
  const auto H = Dump("sphere", 400, 0.05, 2);
  FieldCalibrationOptions o = Method("ellipsoid");
  o.field_norm_uT = 48.0;
  auto c = CalibrateField(H, o);
  ASSERT_TRUE(c.ok()) << c.status().message();
  for (const auto& h : H) EXPECT_NEAR(c->Correct(h).norm(), 48.0, 0.3);
}

TEST(FieldCalibration, GivenFlatSpin_WhenAuto_ThenCircleInThePlaneAndTheAxisOffsetUndetermined) {
  const auto H = Dump("flat", 72, 0.05, 3, Matrix3d::Identity());
  auto c = CalibrateField(H, Method("auto"));
  ASSERT_TRUE(c.ok()) << c.status().message();
  EXPECT_EQ(c->method_used, "circle");
  EXPECT_EQ(c->coverage.weak_axis, "z");
  ASSERT_FALSE(c->warnings.empty());
  EXPECT_NE(c->warnings.front().find("body z"), std::string::npos) << c->warnings.front();
  EXPECT_NEAR(c->offset_uT(0), kOffset_uT(0), 0.05);
  EXPECT_NEAR(c->offset_uT(1), kOffset_uT(1), 0.05);
  // Not determined, and said so: the spin axis is reported; the parameters carry the prior (0) there.
  ASSERT_TRUE(c->OffsetAxisUndetermined());
  EXPECT_GT(std::abs(c->undetermined_axis.z()), 0.999);
  EXPECT_NEAR(c->offset_uT(2), 0.0, 0.02);
  bool said = false;
  for (const auto& w : c->warnings) said = said || w.find("undetermined") != std::string::npos;
  EXPECT_TRUE(said);
}

// A board turned on a table with an HMC5883L-like sensor: the table tilts the spin axis 3° off body
// z, the reading is quantised (gain 1090 LSB/G = 0.0917 µT; gain 230 LSB/G = 0.435 µT), noise
// below or near one LSB, per-axis gains a few % apart, the board at rest for the first `rest`
// samples and a wobble of the axis of up to 1° as it is turned. Returns the true spin axis in *n.
std::vector<Vector3d> Hmc5883lFlatSpin(uint64_t seed, double lsb_uT, double noise_uT, int rest, const Vector3d& b,
                                       Vector3d* n) {
  RngStream rng(seed, "hmc5883l_flat_spin");
  const Vector3d earth_N(25.0, 0.0, 43.3);
  const Eigen::AngleAxisd tilt(3.0 * M_PI / 180.0, Vector3d(0.6, 0.8, 0.0));
  const Matrix3d gains = Eigen::Vector3d(1.0, 1.03, 0.92).asDiagonal();
  *n = tilt.toRotationMatrix().transpose() * Vector3d::UnitZ();
  std::vector<Vector3d> H;
  constexpr int kSamples = 243;
  for (int i = 0; i < kSamples; ++i) {
    const double yaw = i < rest ? 0.0 : 2.3 * M_PI * (i - rest) / (kSamples - rest);
    const Eigen::AngleAxisd wobble(M_PI / 180.0 * std::sin(2.0 * yaw + 0.3), Vector3d(std::cos(3 * yaw), std::sin(3 * yaw), 0));
    const Matrix3d R_NB = (Eigen::AngleAxisd(yaw, Vector3d::UnitZ()) * tilt * wobble).toRotationMatrix();
    const Vector3d raw = gains * (R_NB.transpose() * earth_N) + b + rng.Normal3(noise_uT);
    H.emplace_back((raw / lsb_uT).array().round().matrix() * lsb_uT);
  }
  return H;
}

TEST(FieldCalibration, GivenAHmc5883lFlatSpinOnATiltedTable_WhenAutoOrRobust_ThenNoSampleLostAndTheOffsetInThePlane) {
  const Vector3d b(-18.0, 9.0, -35.0);
  struct Case {
    double lsb_uT, noise_uT;
    int rest;
  };
  // Clean spins: nothing in them is an outlier. At rest for half the dump, a quantised sensor repeats
  // one reading, so the residuals' MAD collapses to zero unless σ is floored at the LSB.
  for (const Case& k : {Case{0.0917, 0.2, 0}, Case{0.0917, 0.15, 60}, Case{0.435, 0.05, 130}, Case{0.256, 0.1, 100}}) {
    for (uint64_t seed : {1, 2, 3}) {
      Vector3d n;
      const auto H = Hmc5883lFlatSpin(seed, k.lsb_uT, k.noise_uT, k.rest, b, &n);
      const Vector3d b_plane = b - b.dot(n) * n;  // what a spin about n determines
      for (const std::string m : {"auto", "robust"}) {
        SCOPED_TRACE(::testing::Message() << m << " lsb " << k.lsb_uT << " rest " << k.rest << " seed " << seed);
        auto c = CalibrateField(H, Method(m));
        ASSERT_TRUE(c.ok()) << c.status().message();
        EXPECT_NE(c->method_used.find("circle"), std::string::npos) << c->method_used;
        EXPECT_TRUE(c->accepted) << c->fit.gate.Failures();
        // Gaussian residuals put 3e-6 of the samples beyond Tukey's 4.685 σ: none of 243 is lost.
        EXPECT_LE(c->downweighted.size(), 1U);
        ASSERT_TRUE(c->OffsetAxisUndetermined());
        EXPECT_GT(std::abs(c->undetermined_axis.dot(n)), std::cos(0.5 * M_PI / 180.0));
        // In the plane within 0.5 µT: 1.1° of heading on this 25 µT horizontal field.
        const Vector3d u = c->undetermined_axis;
        EXPECT_LT(((c->offset_uT - c->offset_uT.dot(u) * u) - (b_plane - b_plane.dot(u) * u)).norm(), 0.5);
        EXPECT_NEAR(c->offset_uT.dot(u), 0.0, 1e-9);  // the prior (nothing known), said to be undetermined
      }
    }
  }
}

TEST(FieldCalibration, GivenSixWildSamplesAmong300_WhenAuto_ThenRobustEllipsoidAndTheGlitchesDownweighted) {
  auto H = Dump("sphere", 300, 0.3, 11);
  // A serial glitch: a dropped byte or another register read in place of the field.
  const std::vector<std::pair<size_t, Vector3d>> glitches = {{17, Vector3d(512.0, -3.0, 40.0)}, {58, Vector3d(-4096.0, -4096.0, -4096.0)},
                                                             {114, Vector3d(3.1, 0.2, -1.0)},   {197, Vector3d(120.0, 455.0, -60.0)},
                                                             {224, Vector3d(-250.0, 8.0, 900.0)}, {268, Vector3d(0.0, 0.0, 0.0)}};
  std::set<size_t> bad;
  for (const auto& [i, v] : glitches) {
    H[i] = v;
    bad.insert(i);
  }
  auto c = CalibrateField(H, Method("auto"));
  ASSERT_TRUE(c.ok()) << c.status().message();
  EXPECT_EQ(c->method_used, "robust-ellipsoid") << c->why;
  EXPECT_EQ(std::set<size_t>(c->downweighted.begin(), c->downweighted.end()), bad);
  EXPECT_LT((c->offset_uT - kOffset_uT).norm(), 0.3);
  EXPECT_TRUE(c->accepted) << c->fit.gate.Failures();
}

TEST(FieldCalibration, GivenAFlatSpin_WhenCalibrated_ThenTheReportAndTheParameterCommentSayTheAxisOffsetIsUndetermined) {
  std::vector<MagSample> s;
  for (const auto& h : Dump("flat", 72, 0.05, 3, Matrix3d::Identity())) s.push_back(MagSample{"", 0, 0, 0, h, {}, {}});
  auto o = Calibrate(s, CalibrateRequest{});
  ASSERT_TRUE(o.ok()) << o.status().message();
  ASSERT_TRUE(o->report["offset_undetermined_along"].is_array());
  EXPECT_GT(std::abs(o->report["offset_undetermined_along"][2].get<double>()), 0.999);
  ASSERT_FALSE(o->param_comments.empty());
  EXPECT_NE(o->param_comments.front().find("UNDETERMINED"), std::string::npos) << o->param_comments.front();
  const std::string parm = ArduPilotParmText(o->ardupilot, "test", o->param_comments);
  EXPECT_NE(parm.find("UNDETERMINED"), std::string::npos) << parm;
}

TEST(FieldCalibration, GivenFlatSpin_WhenEllipsoidRequested_ThenBadInputNamingTheMissingRotation) {
  auto c = CalibrateField(Dump("flat", 72, 0.05, 3), Method("ellipsoid"));
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.status().code(), StatusCode::kBadInput);
  EXPECT_NE(c.status().message().find("body z"), std::string::npos) << c.status().message();
}

TEST(FieldCalibration, GivenAFewOutliers_WhenAuto_ThenRobustAndTheOutliersAreReported) {
  auto H = Dump("sphere", 500, 0.05, 4);
  const std::set<size_t> bad = {7, 123, 321, 444, 499};
  for (size_t i : bad) H[i] *= 1.8;
  auto c = CalibrateField(H, Method("auto"));
  ASSERT_TRUE(c.ok()) << c.status().message();
  EXPECT_EQ(c->method_used, "robust-ellipsoid");
  EXPECT_EQ(std::set<size_t>(c->downweighted.begin(), c->downweighted.end()), bad);
  EXPECT_LT((c->offset_uT - kOffset_uT).norm(), 0.05);
  EXPECT_LT((c->A - TrueK().inverse()).cwiseAbs().maxCoeff(), 0.002);
}

TEST(FieldCalibration, GivenTenSamples_WhenAuto_ThenSphereWithAWarning) {
  auto c = CalibrateField(Dump("sphere", 10, 0.05, 5, Matrix3d::Identity()), Method("auto"));
  ASSERT_TRUE(c.ok()) << c.status().message();
  EXPECT_EQ(c->method_used, "sphere");
  EXPECT_LT((c->offset_uT - kOffset_uT).norm(), 0.2);
  EXPECT_FALSE(c->warnings.empty());
}

TEST(FieldCalibration, GivenFiveSamples_WhenAnyFit_ThenBadInputNamingTheMinimum) {
  auto c = CalibrateField(Dump("sphere", 5, 0.05, 6), Method("auto"));
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.status().code(), StatusCode::kBadInput);
  EXPECT_NE(c.status().message().find("at least 8"), std::string::npos) << c.status().message();
}

TEST(FieldCalibration, GivenCalibratedDataWithLittleRotation_WhenAuto_ThenSaysSoAndFitsNothing) {
  const auto H = Dump("little", 200, 0.05, 7, Matrix3d::Identity(), Vector3d::Zero());
  auto c = CalibrateField(H, Method("auto"));
  ASSERT_TRUE(c.ok()) << c.status().message();
  EXPECT_EQ(c->method_used, "none");
  EXPECT_NE(c->why.find("already consistent"), std::string::npos) << c->why;
  auto s = CalibrateField(H, Method("sphere"));
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.status().code(), StatusCode::kBadInput);
  EXPECT_NE(s.status().message().find("already consistent"), std::string::npos) << s.status().message();
}

TEST(FieldCalibration, GivenGaussAndNanotesla_WhenDetected_ThenUnitsAndOffsetInMicrotesla) {
  for (const auto& [unit, per_uT] : std::vector<std::pair<std::string, double>>{{"G", 0.01}, {"nT", 1000.0}, {"mG", 10.0}}) {
    std::vector<MagSample> s;
    for (const auto& h : Dump("sphere", 300, 0.05, 8)) s.push_back(MagSample{"", 0, 0, 0, h * per_uT, {}, {}});
    auto o = Calibrate(s, CalibrateRequest{});
    ASSERT_TRUE(o.ok()) << o.status().message();
    EXPECT_EQ(o->units.unit, unit);
    EXPECT_LT((o->field.offset_uT - kOffset_uT).norm(), 0.05) << unit;
    EXPECT_EQ(o->units.assumption.find("counts") != std::string::npos, unit == "mG") << o->units.assumption;
  }
  auto bad = DetectUnits({Vector3d(3000, 0, 0), Vector3d(0, 3000, 0)}, "auto", 0.0);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("--units"), std::string::npos);
}

TEST(FieldCalibration, GivenEveryMethod_WhenReported_ThenTheSameKeys) {
  const auto H = Dump("sphere", 300, 0.05, 9);
  std::vector<MagSample> s;
  s.reserve(H.size());
  for (const auto& h : H) s.push_back(MagSample{"", 0, 0, 0, h, {}, {}});
  std::set<std::string> first;
  for (const std::string m : {"none", "sphere", "ellipsoid", "robust", "auto"}) {
    CalibrateRequest rq;
    rq.method = m;
    auto o = Calibrate(s, rq);
    ASSERT_TRUE(o.ok()) << m << ": " << o.status().message();
    std::set<std::string> keys;
    for (const auto& [k, v] : o->report.items()) keys.insert(k);
    if (first.empty()) first = keys;
    EXPECT_EQ(keys, first) << m;
    EXPECT_EQ(o->report["method_used"], m == "auto" ? "ellipsoid" : m == "robust" ? "robust-ellipsoid" : m);
  }
}

TEST(AutopilotParams, GivenAFit_WhenAppliedTheArduPilotAndPx4Way_ThenTheNormIsConsistent) {
  const auto H = Dump("sphere", 400, 0.02, 10);
  auto c = CalibrateField(H, Method("ellipsoid"));
  ASSERT_TRUE(c.ok());
  const ParamList ap = ArduPilotCompassParams(c->offset_uT, c->A, 1);
  const ParamList px4 = Px4CompassParams(c->offset_uT, c->A, 1);
  EXPECT_EQ(ap.front().first, "COMPASS_OFS2_X");
  EXPECT_EQ(px4.front().first, "CAL_MAG1_XOFF");
  std::vector<Vector3d> by_ap, by_px4;
  for (const auto& h : H) {
    by_ap.push_back(ApplyArduPilotCompass(ap, 1, h * 10.0));  // raw in mG
    by_px4.push_back(ApplyPx4Compass(px4, 1, h * 0.01));      // raw in G
  }
  EXPECT_LT(NormSpread(by_ap), 0.002);
  EXPECT_LT(NormSpread(by_px4), 0.002);
  EXPECT_GT(NormSpread(H), 0.03);
  EXPECT_NE(ArduPilotParmText(ap).find("COMPASS_DIA2_X "), std::string::npos);
}

TEST(FieldCalibration, GivenAllZeroOrOutOfRangeReadingsInAGivenUnit_WhenUnitsChecked_ThenBadInputNamingWhy) {
  // A log whose compass is absent logs zeros in uT: no calibration, "already consistent" or otherwise.
  const std::vector<Vector3d> zeros(200, Vector3d::Zero());
  auto z = DetectUnits(zeros, "uT", 0.0);
  ASSERT_FALSE(z.ok());
  EXPECT_EQ(z.status().code(), StatusCode::kBadInput);
  EXPECT_NE(z.status().message().find("absent, disabled or stuck"), std::string::npos) << z.status().message();
  // Almost zero (a log's zeros through its own offsets' inverse, rounding left): said so too.
  std::vector<Vector3d> tiny = zeros;
  for (size_t i = 0; i < tiny.size(); ++i) tiny[i] = Vector3d(1e-8 * static_cast<double>(i % 3), 0.0, 0.0);
  auto t = DetectUnits(tiny, "uT", 0.0);
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.status().message().find("every sample is zero"), std::string::npos) << t.status().message();
  auto big = DetectUnits(Dump("sphere", 100, 0.1, 3), "nT", 0.0);  // µT numbers called nT: 0.05 µT
  ASSERT_FALSE(big.ok());
  EXPECT_NE(big.status().message().find("--units"), std::string::npos) << big.status().message();
  EXPECT_TRUE(DetectUnits(Dump("sphere", 100, 0.1, 3), "uT", 0.0).ok());
}

// A hard iron nearly as large as the Earth field puts the median raw norm below the unit window's
// floor (11 uT), but as the vehicle turns the raw norm still reaches |offset| + |field|: in the log's
// own unit it is a compass field, not "not a compass field in these units" (a public ArduCopter log:
// field 48 uT, offset 47.7 uT, median raw norm 10.5 uT).
TEST(FieldCalibration, GivenAHardIronNearlyCancellingTheField_WhenUnitsGiven_ThenItIsAccepted) {
  const Vector3d offset(0.0, 0.0, -46.0);
  std::vector<Vector3d> raw;
  for (int i = 0; i < 400; ++i) {
    // Mostly near level with the field pointing down, so the offset cancels it; some rotation.
    const double a = 0.05 * i, tilt = (i % 10 == 0) ? 1.2 : 0.15;
    raw.emplace_back(offset + 48.0 * Vector3d(std::sin(tilt) * std::cos(a), std::sin(tilt) * std::sin(a), std::cos(tilt)));
  }
  auto g = DetectUnits(raw, "uT", 0.0);
  ASSERT_TRUE(g.ok()) << g.status().message();
  EXPECT_NE(g->assumption.find("95th percentile"), std::string::npos) << g->assumption;
  EXPECT_FALSE(DetectUnits(raw, "nT", 0.0).ok());  // the same numbers in nT read no field at all
}

}  // namespace
}  // namespace hexsim::magnetics
