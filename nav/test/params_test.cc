#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "hexsim/common/rng.h"
#include "hexsim/common/rotation.h"
#include "hexsim/common/yaml_reader.h"
#include "hexsim/nav/estimator.h"
#include "hexsim/nav/nav_io.h"
#include "support/synthetic.h"

namespace hexsim::nav {
namespace {

Status ParseText(const std::string& text, NavParams* p) {
  auto node = YamlReader::LoadString(text, "nav.yaml");
  EXPECT_TRUE(node.ok());
  YamlReader r(node.value()["nav"], "nav.yaml", "nav");
  return ParseNavParams(r, p);
}

TEST(NavParams, GivenYamlWithNavKeys_WhenParsed_ThenFieldsAreSetAndOthersKeepDefaults) {
  NavParams p;
  const Status s = ParseText(
      "nav:\n  estimator: complementary\n  mag_mode: 3axis\n  gps_delay_s: 0.15\n"
      "  earth_B_N_uT: [20, 1, 45]\n  cov_predict_every_n: 2\n", &p);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(p.estimator, "complementary");
  EXPECT_EQ(p.mag_mode, MagMode::kThreeAxis);
  EXPECT_DOUBLE_EQ(p.gps_delay_s, 0.15);
  EXPECT_EQ(p.cov_predict_every_n, 2);
  EXPECT_DOUBLE_EQ(p.earth.B_N_uT.z(), 45.0);
  EXPECT_DOUBLE_EQ(p.gps_pos_std_m, NavParams().gps_pos_std_m);
  EXPECT_TRUE(ValidateNavParams(p).ok());
}

TEST(NavParams, GivenAnUnknownKeyOrABadValue_WhenParsed_ThenBadInputNamesTheField) {
  NavParams p;
  Status s = ParseText("nav:\n  gyro_noise: 0.1\n", &p);
  EXPECT_EQ(s.code(), StatusCode::kBadInput);
  EXPECT_NE(s.message().find("gyro_noise"), std::string::npos) << s.message();
  s = ParseText("nav:\n  gps_pos_std_m: -1\n", &p);
  EXPECT_EQ(s.code(), StatusCode::kBadInput);
  EXPECT_NE(s.message().find("gps_pos_std_m"), std::string::npos) << s.message();
  s = ParseText("nav:\n  mag_mode: fancy\n", &p);
  EXPECT_EQ(s.code(), StatusCode::kBadInput);
}

TEST(NavParams, GivenAnUnknownEstimatorOrNoEarthField_WhenMade_ThenBadInput) {
  NavParams p;
  p.earth.B_N_uT = testing::DefaultEarthField_N_uT();
  EXPECT_EQ(MakeEstimator("ukf", p).status().code(), StatusCode::kBadInput);
  EXPECT_TRUE(MakeEstimator("eskf", p).ok());
  EXPECT_TRUE(MakeEstimator("complementary", p).ok());
  p.earth.B_N_uT = Eigen::Vector3d(0, 0, 50);  // no horizontal component: no heading
  const auto r = MakeEstimator("eskf", p);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("earth_B_N_uT"), std::string::npos);
}

TEST(Heading, GivenRandomAttitudes_WhenTiltCompensated_ThenHeadingPlusDeclinationIsTheTrueYaw) {
  RngStream rng(31, "heading_property");
  EarthFieldReference earth;
  earth.B_N_uT = testing::DefaultEarthField_N_uT();
  for (int i = 0; i < 500; ++i) {
    const double roll = (rng.Uniform() - 0.5) * 2.0 * 70 * kDegToRad;
    const double pitch = (rng.Uniform() - 0.5) * 2.0 * 70 * kDegToRad;
    const double yaw = (rng.Uniform() - 0.5) * 2.0 * kPi;
    const Eigen::Quaterniond q = QuatFromEuler(roll, pitch, yaw);
    const Eigen::Vector3d m_B = q.conjugate() * earth.B_N_uT;
    const double psi = TiltCompensatedHeadingRad(m_B, roll, pitch) + DeclinationRad(earth);
    ASSERT_NEAR(WrapPi(psi - yaw), 0.0, 1e-9) << "roll " << roll << " pitch " << pitch;
    // And the independent levelling formula in the test support agrees on a disturbed field.
    const Eigen::Vector3d m_dist = m_B + rng.Normal3(3.0);
    ASSERT_NEAR(WrapPi(TiltCompensatedHeadingRad(m_dist, roll, pitch) + DeclinationRad(earth) -
                       testing::CompassHeadingRad(m_dist, q, earth.B_N_uT)),
                0.0, 1e-9);
  }
}

}  // namespace
}  // namespace hexsim::nav
