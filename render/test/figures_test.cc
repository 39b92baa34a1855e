// The standard figures and the paper-figure helpers render from plain data.
#include "hexsim/render/figures.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <set>

#include "hexsim/common/rotation.h"

namespace hexsim::render {
namespace {

namespace fs = std::filesystem;

size_t NonWhite(const Image& img) {
  size_t n = 0;
  for (size_t i = 0; i < img.rgba.size(); i += 4) {
    if (img.rgba[i] < 240 || img.rgba[i + 1] < 240 || img.rgba[i + 2] < 240) ++n;
  }
  return n;
}

// A 20 s flight at 20 Hz: climb, a circle of 10 m radius, every core channel present.
logs::FlightLog SyntheticLog() {
  logs::FlightLog log;
  for (int i = 0; i < 400; ++i) {
    const double t = 0.05 * i, a = 0.3 * t;
    log.AppendRow();
    log.Set("t_s", t);
    log.Set("pos_N_m", 10.0 * std::cos(a));
    log.Set("pos_E_m", 10.0 * std::sin(a));
    log.Set("pos_D_m", -std::min(5.0, t));
    log.Set("est_pos_N_m", 10.0 * std::cos(a) + 0.3);
    log.Set("est_pos_E_m", 10.0 * std::sin(a) - 0.2);
    log.Set("est_pos_D_m", -std::min(5.0, t) + 0.1);
    log.Set("gps_N_m", 10.0 * std::cos(a) + 0.5 * std::sin(7.0 * t));
    log.Set("gps_E_m", 10.0 * std::sin(a) + 0.5 * std::cos(5.0 * t));
    log.Set("gps_D_m", -std::min(5.0, t));
    log.Set("baro_alt_m", std::min(5.0, t) + 0.2 * std::sin(t));
    const Eigen::Quaterniond q = QuatFromEuler(0.05 * std::sin(t), 0.04 * std::cos(t), WrapPi(a + kPi / 2));
    const Eigen::Quaterniond qe = QuatFromEuler(0.05 * std::sin(t), 0.04 * std::cos(t), WrapPi(a + kPi / 2 + 0.03));
    log.Set("q_w", q.w());
    log.Set("q_x", q.x());
    log.Set("q_y", q.y());
    log.Set("q_z", q.z());
    log.Set("est_q_w", qe.w());
    log.Set("est_q_x", qe.x());
    log.Set("est_q_y", qe.y());
    log.Set("est_q_z", qe.z());
    log.Set("yaw_true_deg", YawDeg(q));
    log.Set("yaw_est_deg", YawDeg(qe));
    log.Set("mag_x_uT", 20.0 * std::cos(a));
    log.Set("mag_y_uT", -20.0 * std::sin(a));
    log.Set("mag_z_uT", 45.0);
    log.Set("mag2_x_uT", 21.0 * std::cos(a));
    log.Set("mag2_y_uT", -19.0 * std::sin(a));
    log.Set("mag2_z_uT", 44.0 + 0.1 * t);
    log.Set("current_A", 12.0 + 3.0 * std::sin(t));
    log.Set("voltage_V", 16.8 - 0.05 * t);
    log.Set("control_u", 420.0 + 30.0 * std::sin(t));
    for (int m = 1; m <= 6; ++m) {
      log.Set("motor_" + std::to_string(m) + "_u", 0.45 + 0.02 * m + 0.03 * std::sin(t + m));
      log.Set("motor_" + std::to_string(m) + "_A", 2.0 + 0.5 * std::sin(t + m));
    }
    log.Set("mode", t < 5.0 ? 1.0 : (t < 15.0 ? 2.0 : 3.0));
  }
  return log;
}

class FiguresTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ::unsetenv("DISPLAY");
    dir_ = fs::path(::testing::TempDir()) /
           ("render_fig_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(FiguresTest, GivenALogWithEveryCoreChannelThenEveryStandardFigureIsWrittenAndDrawn) {
  std::vector<std::string> written;
  const Status st = RenderStandardFigures(SyntheticLog(), dir_.string(), &written);
  ASSERT_TRUE(st.ok()) << st.message();
  std::set<std::string> names;
  for (const std::string& p : written) names.insert(fs::path(p).filename().string());
  for (const char* expected : {"track_top.png", "track_3d.png", "altitude.png", "attitude.png", "yaw_error.png",
                               "compass_mag.png", "compass_mag2.png", "power.png", "motors.png"}) {
    EXPECT_EQ(names.count(expected), 1u) << expected;
  }
  EXPECT_EQ(names.size(), written.size());
  for (const std::string& p : written) {
    Result<Image> img = ReadPng(p);
    ASSERT_TRUE(img.ok()) << p;
    // A drawn figure: well beyond a frame and a title, yet mostly white background.
    const double ink = static_cast<double>(NonWhite(*img)) / (img->width * img->height);
    EXPECT_GT(ink, 0.02) << p;
    EXPECT_LT(ink, 0.7) << p;
  }
}

TEST_F(FiguresTest, GivenALogWithOnlyElectricalChannelsThenOnlyThePowerFigureIsWritten) {
  logs::FlightLog log;
  for (int i = 0; i < 50; ++i) {
    log.AppendRow();
    log.Set("t_s", 0.1 * i);
    log.Set("current_A", 5.0 + 0.1 * i);
  }
  log.AddColumn("voltage_V");  // present but empty: no data, so not plotted
  std::vector<std::string> written;
  ASSERT_TRUE(RenderStandardFigures(log, dir_.string(), &written).ok());
  ASSERT_EQ(written.size(), 1u);
  EXPECT_EQ(fs::path(written[0]).filename(), "power.png");
}

TEST_F(FiguresTest, GivenALogWithoutTimeThenItIsBadInput) {
  logs::FlightLog log;
  log.AppendRow();
  log.Set("current_A", 1.0);
  std::vector<std::string> written;
  EXPECT_EQ(RenderStandardFigures(log, dir_.string(), &written).code(), StatusCode::kBadInput);
  EXPECT_TRUE(written.empty());
}

TEST_F(FiguresTest, GivenPaperFigureInputsThenEachHelperRendersANonBlankImage) {
  Track planned{"planned", {0, 20, 20, 0, 0}, {0, 0, 20, 20, 0}, {-10, -10, -10, -10, -10}, {}};
  Track flown{"adaptive", {}, {}, {}, {}};
  for (int i = 0; i <= 100; ++i) {
    flown.north_m.push_back(20.0 * std::min(1.0, i / 25.0));
    flown.east_m.push_back(0.3 * std::sin(0.2 * i));
    flown.down_m.push_back(-10.0);
  }
  Result<Image> tracks = RenderTracks(planned, {flown}, 800, 380);
  ASSERT_TRUE(tracks.ok()) << tracks.status().message();
  EXPECT_GT(NonWhite(*tracks), 5000u);

  std::vector<double> angle;
  NamedCurve trad{"traditional", {}}, adapt{"adaptive", {}};
  for (int a = 0; a <= 360; a += 10) {
    angle.push_back(a);
    trad.values.push_back(6.0 * std::sin(a * kDegToRad + 0.3));
    adapt.values.push_back(1.0 * std::sin(a * kDegToRad));
  }
  Result<Image> residual = RenderHeadingResidual(angle, {trad, adapt}, 600, 380);
  ASSERT_TRUE(residual.ok());
  EXPECT_GT(NonWhite(*residual), 3000u);
  EXPECT_EQ(RenderHeadingResidual(angle, {{"short", {1.0}}}).status().code(), StatusCode::kBadInput);

  std::vector<SampleCloud> clouds;
  std::vector<Ellipsoid3D> fits;
  for (int k = 0; k < 3; ++k) {
    Ellipsoid3D e;
    e.centre = {5.0 * k, -2.0 * k, 1.0 * k};
    e.shape = {{{50.0, 2.0, 0.0}, {0.0, 45.0, 1.0}, {0.0, 0.0, 40.0}}};
    SampleCloud c;
    c.label = "u = " + std::to_string(200 * k);
    for (int i = 0; i < 120; ++i) {
      const double th = std::acos(1.0 - 2.0 * (i + 0.5) / 120.0), ph = 2.399963 * i;
      const Point3 u = {std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)};
      Point3 p{};
      for (size_t r = 0; r < 3; ++r) p[r] = e.centre[r] + e.shape[r][0] * u[0] + e.shape[r][1] * u[1] + e.shape[r][2] * u[2];
      c.points_uT.push_back(p);
    }
    clouds.push_back(c);
    fits.push_back(e);
  }
  Result<Image> ellipsoids = RenderEllipsoidClouds(clouds, fits, 700, 600);
  ASSERT_TRUE(ellipsoids.ok()) << ellipsoids.status().message();
  EXPECT_GT(NonWhite(*ellipsoids), 10000u);

  Result<Image> line = RenderCentreLine({fits[0].centre, fits[1].centre, fits[2].centre}, {"0", "200", "400"},
                                        fits[0].centre, {5.0, -2.0, 1.0}, 700, 600);
  ASSERT_TRUE(line.ok()) << line.status().message();
  EXPECT_GT(NonWhite(*line), 5000u);
  EXPECT_EQ(RenderCentreLine({fits[0].centre}, {}, {0, 0, 0}, {0, 0, 0}).status().code(), StatusCode::kBadInput);
}

// Support function of an ellipsoid {c + M·u}: its extent along axis a is c_a ± |row_a(M)|, and its
// projected outline must touch exactly those extremes.
TEST(ProjectedOutlineTest, GivenARotatedEllipsoidThenTheOutlineReachesTheSupportExtremes) {
  Ellipsoid3D e;
  const Eigen::Matrix3d R = QuatFromEuler(0.4, -0.3, 1.1).toRotationMatrix();
  const Eigen::Matrix3d M = R * Eigen::Vector3d(30.0, 20.0, 10.0).asDiagonal();
  e.centre = {1.0, -2.0, 3.0};
  for (int r = 0; r < 3; ++r) e.shape[static_cast<size_t>(r)] = {M(r, 0), M(r, 1), M(r, 2)};
  for (auto [a, b] : {std::pair{0, 1}, {1, 2}, {0, 2}}) {
    const auto outline = ProjectedOutline(e, a, b, 2000);
    double amax = -1e9, bmax = -1e9, amin = 1e9;
    for (const auto& p : outline) {
      amax = std::max(amax, p[0]);
      amin = std::min(amin, p[0]);
      bmax = std::max(bmax, p[1]);
    }
    const double ra = M.row(a).norm(), rb = M.row(b).norm();
    const double tol = 1e-4 * 30.0;  // chord error of 2000 segments
    EXPECT_NEAR(amax, e.centre[static_cast<size_t>(a)] + ra, tol);
    EXPECT_NEAR(amin, e.centre[static_cast<size_t>(a)] - ra, tol);
    EXPECT_NEAR(bmax, e.centre[static_cast<size_t>(b)] + rb, tol);
  }
}

// Plots named phases "mode 0", "mode 2": the numbers are the autopilot's, named by the log's meta.
TEST(FlightModeLabel, GivenALogsFormatWhenAModeNumberIsNamedThenItIsTheAutopilotsName) {
  const nlohmann::json ardupilot = {{"format", "ardupilot-dataflash"}, {"vehicle_type", "copter"}};
  EXPECT_EQ(FlightModeLabel(ardupilot, 0), "Stabilize");
  EXPECT_EQ(FlightModeLabel(ardupilot, 5), "Loiter");
  EXPECT_EQ(FlightModeLabel(ardupilot, 16), "PosHold");
  EXPECT_EQ(FlightModeLabel(ardupilot, 8), "mode 8");  // not a Copter mode number
  EXPECT_EQ(FlightModeLabel({{"format", "ardupilot-dataflash"}, {"vehicle_type", "plane"}}, 5), "mode 5");
  const nlohmann::json px4 = {{"format", "px4-ulog"}};
  EXPECT_EQ(FlightModeLabel(px4, 3), "Mission");
  EXPECT_EQ(FlightModeLabel(px4, 2), "Position");
  const nlohmann::json sim = {{"mode_names", {{"2", "waypoint"}}}};
  EXPECT_EQ(FlightModeLabel(sim, 2), "waypoint");
  EXPECT_EQ(FlightModeLabel(nlohmann::json::object(), 2), "mode 2");
  EXPECT_EQ(FlightModeLabel(ardupilot, 2.5), "mode 2.5");
}

}  // namespace
}  // namespace hexsim::render
