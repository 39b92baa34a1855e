#include "hexsim/magnetics/wmm.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hexsim/common/rotation.h"

namespace hexsim::magnetics {
namespace {

// One row of NOAA's official test values: date, alt (km), lat, lon, X, Y, Z, H, F (nT), incl, decl (deg).
struct TestPoint {
  double year = 0, alt_km = 0, lat_deg = 0, lon_deg = 0;
  double x_nT = 0, y_nT = 0, z_nT = 0, h_nT = 0, f_nT = 0, incl_deg = 0, decl_deg = 0;
  int line = 0;
};

// id "wmm2015v2" → data/wmm/test_values_2015v2.csv
std::vector<TestPoint> ReadTestPoints(const std::string& id) {
  const std::string path = std::string(HEXSIM_SOURCE_DIR) + "/data/wmm/test_values_" + id.substr(3) + ".csv";
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  std::vector<TestPoint> points;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line_no == 1 || line.empty()) continue;  // header
    std::stringstream ss(line);
    std::vector<double> v;
    std::string cell;
    while (std::getline(ss, cell, ',')) v.push_back(std::stod(cell));
    EXPECT_EQ(v.size(), 12u) << path << ":" << line_no;
    if (v.size() != 12u) continue;
    TestPoint p;
    p.year = v[0];
    p.alt_km = v[1];
    p.lat_deg = v[2];
    p.lon_deg = v[3];
    p.x_nT = v[4];
    p.y_nT = v[5];
    p.z_nT = v[6];
    p.h_nT = v[7];
    p.f_nT = v[8];
    p.incl_deg = v[9];
    p.decl_deg = v[10];
    p.line = line_no;
    points.push_back(p);
  }
  return points;
}

// NOAA's tolerances for a conforming implementation: field components within 1 nT, angles within
// 0.01° (the published angles are rounded to 0.01°, so allow that rounding on top of the model's error).
constexpr double kFieldTol_uT = 0.001;
constexpr double kAngleTol_deg = 0.01;

class WmmOfficialPoints : public ::testing::TestWithParam<std::string> {};

TEST_P(WmmOfficialPoints, GivenOfficialTestPoints_WhenEvaluated_ThenComponentsWithin1nTAndAnglesWithin001Deg) {
  const std::string id = GetParam();
  const std::vector<TestPoint> points = ReadTestPoints(id);
  ASSERT_GE(points.size(), 12u);
  for (const TestPoint& p : points) {
    SCOPED_TRACE("test_values_" + id.substr(3) + ".csv:" + std::to_string(p.line));
    const GeodeticPoint where{p.lat_deg, p.lon_deg, p.alt_km * 1000.0};
    const Result<EarthField> by_epoch = EvaluateWmmModel(id, where, p.year);
    ASSERT_TRUE(by_epoch.ok()) << by_epoch.status().message();
    EXPECT_EQ(by_epoch->model_id, id);
    const Result<EarthField> by_date = EvaluateWmm(where, p.year);
    ASSERT_TRUE(by_date.ok()) << by_date.status().message();
    // The date alone picks this model for every official point, except the superseded original WMM2015.
    EXPECT_EQ(by_date->model_id, id == "wmm2015" ? "wmm2015v2" : id);
    const EarthField& f = *by_epoch;
    EXPECT_NEAR(f.B_N_uT.x(), p.x_nT / 1000.0, kFieldTol_uT);
    EXPECT_NEAR(f.B_N_uT.y(), p.y_nT / 1000.0, kFieldTol_uT);
    EXPECT_NEAR(f.B_N_uT.z(), p.z_nT / 1000.0, kFieldTol_uT);
    EXPECT_NEAR(f.horizontal_uT, p.h_nT / 1000.0, kFieldTol_uT);
    EXPECT_NEAR(f.total_uT, p.f_nT / 1000.0, kFieldTol_uT);
    EXPECT_NEAR(f.inclination_deg, p.incl_deg, kAngleTol_deg);
    EXPECT_NEAR(f.declination_deg, p.decl_deg, kAngleTol_deg);
  }
}

INSTANTIATE_TEST_SUITE_P(AllModels, WmmOfficialPoints, ::testing::Values("wmm2015", "wmm2015v2", "wmm2020", "wmm2025"),
                         [](const ::testing::TestParamInfo<std::string>& info) { return info.param; });

TEST(Wmm, GivenWmm2015AndItsV2_WhenEvaluatedIn2019_ThenTheyDifferByTheCorrection) {
  // NOAA replaced WMM2015 in 2018 because it had drifted by up to ~190 nT: v2 and the original
  // differ by tens to hundreds of nT in 2019 somewhere, and by far less than the field.
  double max_nT = 0.0;
  for (double lat = -80; lat <= 80; lat += 20) {
    for (double lon = -180; lon < 180; lon += 30) {
      const auto a = EvaluateWmmModel("wmm2015", {lat, lon, 0.0}, 2019.5);
      const auto b = EvaluateWmmModel("wmm2015v2", {lat, lon, 0.0}, 2019.5);
      ASSERT_TRUE(a.ok() && b.ok());
      max_nT = std::max(max_nT, (a->B_N_uT - b->B_N_uT).norm() * 1000.0);
    }
  }
  EXPECT_GT(max_nT, 50.0);
  EXPECT_LT(max_nT, 400.0);
  EXPECT_EQ(WmmModelIds(), (std::vector<std::string>{"wmm2015", "wmm2015v2", "wmm2020", "wmm2025"}));
  const auto out = EvaluateWmmModel("wmm2015", {0.0, 0.0, 0.0}, 2021.2);
  ASSERT_FALSE(out.ok());
  EXPECT_NE(out.status().message().find("2021.2 outside wmm2015 validity 2015.0–2020.0"), std::string::npos)
      << out.status().message();
  EXPECT_EQ(EvaluateWmmModel("wmm1990", {0.0, 0.0, 0.0}, 2016.0).status().code(), StatusCode::kBadInput);
}

TEST(Wmm, GivenDates_WhenConverted_ThenNoaaDecimalYears) {
  EXPECT_DOUBLE_EQ(*DecimalYearFromDate("2016.5"), 2016.5);
  EXPECT_DOUBLE_EQ(*DecimalYearFromDate("2015-01-01"), 2015.0);
  EXPECT_DOUBLE_EQ(*DecimalYearFromDate("2016-07-02"), 2016.0 + 183.0 / 366.0);  // leap year
  EXPECT_DOUBLE_EQ(*DecimalYearFromDate("2019-12-31"), 2019.0 + 364.0 / 365.0);
  for (const char* bad : {"2019-02-29", "2016-13-01", "2016/07/02", "yesterday", "", "2016-07-02x"}) {
    EXPECT_EQ(DecimalYearFromDate(bad).status().code(), StatusCode::kBadInput) << bad;
  }
}

TEST(Wmm, GivenDateOutsideValidity_WhenEvaluatedWithoutExtrapolation_ThenBadInputNamingTheYear) {
  const GeodeticPoint where{43.88, 125.35, 200.0};
  for (double year : {2014.99, 2030.01, 1990.0, 2100.0}) {
    const Result<EarthField> r = EvaluateWmm(where, year);
    ASSERT_FALSE(r.ok()) << year;
    EXPECT_EQ(r.status().code(), StatusCode::kBadInput);
    EXPECT_NE(r.status().message().find("decimal_year"), std::string::npos) << r.status().message();
    EXPECT_NE(r.status().message().find("outside WMM validity 2015.0–2030.0"), std::string::npos);
  }
  // The year is printed as given (a %.4g format once printed 2030.4 as "2030").
  EXPECT_NE(EvaluateWmm(where, 2030.4).status().message().find("2030.4 outside"), std::string::npos);
}

TEST(Wmm, GivenDateOutsideValidity_WhenExtrapolationAllowed_ThenNearestEpochIsUsed) {
  const GeodeticPoint where{43.88, 125.35, 200.0};
  const Result<EarthField> early = EvaluateWmm(where, 2013.0, /*allow_extrapolation=*/true);
  ASSERT_TRUE(early.ok());
  EXPECT_EQ(early->model, "WMM-2015v2");
  const Result<EarthField> late = EvaluateWmm(where, 2031.0, /*allow_extrapolation=*/true);
  ASSERT_TRUE(late.ok());
  EXPECT_EQ(late->model, "WMM-2025");
  // Extrapolating is exactly evaluating that epoch's coefficients at that date.
  const Result<EarthField> direct = EvaluateWmmEpoch(2025, where, 2031.0);
  ASSERT_TRUE(direct.ok());
  EXPECT_EQ(late->B_N_uT, direct->B_N_uT);
}

TEST(Wmm, GivenEpochBoundaries_WhenEvaluated_ThenTheNewerModelOwnsTheBoundaryAnd2030BelongsToWmm2025) {
  EXPECT_EQ(WmmEpochs(), (std::vector<int>{2015, 2020, 2025}));
  const GeodeticPoint where{0.0, 0.0, 0.0};
  EXPECT_EQ(EvaluateWmm(where, 2015.0)->model, "WMM-2015v2");
  EXPECT_EQ(EvaluateWmm(where, 2019.999)->model, "WMM-2015v2");
  EXPECT_EQ(EvaluateWmm(where, 2020.0)->model, "WMM-2020");
  EXPECT_EQ(EvaluateWmm(where, 2025.0)->model, "WMM-2025");
  EXPECT_EQ(EvaluateWmm(where, 2030.0)->model, "WMM-2025");
}

TEST(Wmm, GivenBadPointOrEpoch_WhenEvaluated_ThenBadInput) {
  EXPECT_EQ(EvaluateWmm({91.0, 0.0, 0.0}, 2020.0).status().code(), StatusCode::kBadInput);
  EXPECT_EQ(EvaluateWmm({0.0, 0.0, -5000.0}, 2020.0).status().code(), StatusCode::kBadInput);
  EXPECT_EQ(EvaluateWmm({0.0, 0.0, 0.0}, std::nan("")).status().code(), StatusCode::kBadInput);
  EXPECT_EQ(EvaluateWmmEpoch(2010, {0.0, 0.0, 0.0}, 2012.0).status().code(), StatusCode::kBadInput);
}

TEST(Wmm, GivenPaperLocation_WhenEvaluatedIn2016_ThenTotalFieldIsAMidLatitudeNorthernField) {
  // Changchun, 43.88 N 125.35 E, 200 m, 2016.5: |B| ≈ 53–56 µT, dipping steeply down, small west declination.
  const Result<EarthField> f = EvaluateWmm({43.88, 125.35, 200.0}, 2016.5);
  ASSERT_TRUE(f.ok());
  EXPECT_EQ(f->model, "WMM-2015v2");
  EXPECT_GT(f->total_uT, 53.0);
  EXPECT_LT(f->total_uT, 56.0);
  EXPECT_GT(f->inclination_deg, 55.0);
  EXPECT_LT(f->inclination_deg, 70.0);
  EXPECT_LT(std::abs(f->declination_deg), 15.0);
}

TEST(Wmm, GivenAPole_WhenEvaluated_ThenTheFieldIsFiniteAndContinuousWithANearbyPoint) {
  // The east component uses P_n^m / sin θ from its own recursion, so the exact pole is not singular.
  for (double lat : {90.0, -90.0}) {
    const Result<EarthField> at_pole = EvaluateWmm({lat, 0.0, 0.0}, 2025.0);
    ASSERT_TRUE(at_pole.ok());
    ASSERT_TRUE(at_pole->B_N_uT.allFinite());
    // 1e-6 deg ≈ 0.1 m away the field differs by far less than 1 nT (gradients are ~ 0.03 nT/m at most).
    const Result<EarthField> near = EvaluateWmm({lat - std::copysign(1e-6, lat), 0.0, 0.0}, 2025.0);
    ASSERT_TRUE(near.ok());
    EXPECT_LT((at_pole->B_N_uT - near->B_N_uT).norm(), 1e-3);
  }
}

TEST(Wmm, GivenAnyPoint_WhenEvaluated_ThenDerivedQuantitiesAgreeWithTheVector) {
  const Result<EarthField> f = EvaluateWmm({-33.9, 18.4, 1500.0}, 2027.3);
  ASSERT_TRUE(f.ok());
  const Eigen::Vector3d& B = f->B_N_uT;
  EXPECT_NEAR(f->horizontal_uT, std::hypot(B.x(), B.y()), 1e-12);
  EXPECT_NEAR(f->total_uT, B.norm(), 1e-12);
  EXPECT_NEAR(std::tan(f->declination_deg * kDegToRad), B.y() / B.x(), 1e-9);
}

}  // namespace
}  // namespace hexsim::magnetics
