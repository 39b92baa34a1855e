// calibrate's physical ranges come from the one plausibility table, and a fit outside them is
// reported as a model mismatch (dumps generated here).
#include "hexsim/magnetics/calibration_ranges.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "hexsim/magnetics/ellipsoid_fit.h"
#include "hexsim/magnetics/field_calibration.h"

namespace hexsim::magnetics {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

TEST(CalibrationRanges, GivenTheTable_WhenRead_ThenEveryCalibrateRowExistsWithAReasonAndTheGateUsesIt) {
  for (const char* name : {"earth_field_norm", "raw_field_norm", "compass_offset", "calibration_radius",
                           "soft_iron_diagonal", "soft_iron_off_diagonal", "soft_iron_condition"}) {
    const auto* r = plausibility::FindRange(name);
    ASSERT_NE(r, nullptr) << name;
    EXPECT_LT(r->lo, r->hi) << name;
    EXPECT_FALSE(r->reason.empty()) << name;
  }
  EXPECT_EQ(CalibrationRange("earth_field_norm").lo, 22.0);
  EXPECT_EQ(CalibrationRange("earth_field_norm").hi, 67.0);
  const EllipsoidFitOptions o;
  EXPECT_EQ(o.min_radius_uT, plausibility::FindRange("calibration_radius")->lo);
  EXPECT_EQ(o.max_off_diagonal, plausibility::FindRange("soft_iron_off_diagonal")->hi);
  EXPECT_TRUE(std::isinf(CalibrationRange("no_such_row").hi));
}

TEST(CalibrationRanges, GivenNormsAtTheUnitWindowsEdges_WhenDetected_ThenInsideIsMicroteslaAndOutsideIsNot) {
  const double lo = CalibrationRange("raw_field_norm").lo, hi = CalibrationRange("raw_field_norm").hi;
  auto unit = [](double norm) {
    return DetectUnits({Vector3d(norm, 0, 0), Vector3d(0, norm, 0), Vector3d(0, 0, norm)}, "auto", 0.0);
  };
  EXPECT_EQ(unit(lo * 1.01)->unit, "uT");
  EXPECT_EQ(unit(hi * 0.99)->unit, "uT");
  EXPECT_EQ(unit(hi * 0.99 * 10)->unit, "mG");  // beyond the µT window, inside it as milligauss
  EXPECT_EQ(unit(lo * 0.99).status().code(), StatusCode::kBadInput);  // no unit puts ~11 µT / 10 in range
}

// A whole sphere, |B| = 50 µT, through soft iron K and hard iron b.
std::vector<Vector3d> Sphere(const Matrix3d& K, const Vector3d& b) {
  std::vector<Vector3d> H;
  const int n = 400;
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / n, rho = std::sqrt(1.0 - z * z), phi = 2.39996322972865332 * i;
    H.emplace_back(K * Vector3d(50 * rho * std::cos(phi), 50 * rho * std::sin(phi), 50 * z) + b);
  }
  return H;
}

bool SaysMismatch(const FieldCalibration& c, const std::string& what) {
  for (const auto& w : c.warnings) {
    if (w.find("model mismatch") != std::string::npos && w.find(what) != std::string::npos) return true;
  }
  return false;
}

TEST(CalibrationRanges, GivenAnOffsetOrAShapeNoCompassHas_WhenFitted_ThenModelMismatchNotAResult) {
  FieldCalibrationOptions o;
  o.method = "sphere";
  auto normal = CalibrateField(Sphere(Matrix3d::Identity(), Vector3d(20, -10, 30)), o);
  ASSERT_TRUE(normal.ok()) << normal.status().message();
  EXPECT_FALSE(SaysMismatch(*normal, "offset"));
  auto magnet = CalibrateField(Sphere(Matrix3d::Identity(), Vector3d(150, -120, 90)), o);  // |b| = 212 µT
  ASSERT_TRUE(magnet.ok()) << magnet.status().message();
  EXPECT_TRUE(SaysMismatch(*magnet, "offset"));
  o.method = "ellipsoid";
  const Matrix3d half_axis = Vector3d(1.4, 1.4, 0.51).asDiagonal();  // det ≈ 1, one axis at a third of the others
  auto broken = CalibrateField(Sphere(half_axis, Vector3d(5, 5, 5)), o);
  ASSERT_TRUE(broken.ok()) << broken.status().message();
  EXPECT_TRUE(SaysMismatch(*broken, "soft-iron condition"));
  EXPECT_FALSE(broken->accepted);  // the gate's diagonal bounds reject it too
}

}  // namespace
}  // namespace hexsim::magnetics
