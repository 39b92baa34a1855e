// `hexsim calibrate LOG.ulg` on a PX4 log the test writes: the magnetometer topic is already
// calibrated (vehicle_magnetometer) with a stale calibration in force; the parameters written must be
// absolute, in the slot whose CAL_MAGn_ID is the sensor's, and correct the raw field the way PX4 does.
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "hexsim/magnetics/autopilot_params.h"
#include "support/ulog_writer.h"

namespace {

namespace fs = std::filesystem;
using hexsim::logs::testing::Pack;

TEST(CalibrateULog, GivenACalibratedTopicWithAStaleCalibration_WhenCalibrated_ThenPx4ParamsAreAbsoluteInTheMatchedSlot) {
  // Truth: raw = K·B + b (gauss), |B| = 0.5 G over the whole sphere, b = (0.15, −0.25, 0.2) G.
  const Eigen::Vector3d b(0.15, -0.25, 0.2);
  const Eigen::Matrix3d K = (Eigen::Matrix3d() << 1.06, 0.02, 0.0, 0.02, 0.95, -0.01, 0.0, -0.01, 1.0).finished();
  // In force (stale): slot 2 holds this sensor (device id 4242), rotation yaw 90° (CAL_MAG2_ROT 2).
  const Eigen::Vector3d off(0.05, -0.1, 0.1);
  const Eigen::Matrix3d S = Eigen::Vector3d(1.02, 0.99, 1.0).asDiagonal();
  const Eigen::Matrix3d R = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  hexsim::logs::testing::ULogWriter w;
  w.ParamInt("CAL_MAG0_ID", 11);
  w.ParamInt("CAL_MAG2_ID", 4242);
  w.ParamInt("CAL_MAG2_ROT", 2);
  const char* axes[3] = {"X", "Y", "Z"};
  for (int k = 0; k < 3; ++k) {
    w.Param(std::string("CAL_MAG2_") + axes[k] + "OFF", static_cast<float>(off(k)));
    w.Param(std::string("CAL_MAG2_") + axes[k] + "SCALE", static_cast<float>(S(k, k)));
  }
  w.Format("vehicle_attitude:uint64_t timestamp;float[4] q;");
  w.Format("vehicle_magnetometer:uint64_t timestamp;uint32_t device_id;float[3] magnetometer_ga;");
  const uint16_t att = w.Subscribe("vehicle_attitude", 0), vm = w.Subscribe("vehicle_magnetometer", 0);
  const int n = 300;
  std::vector<Eigen::Vector3d> raw;
  for (int i = 0; i <= n; ++i) {
    const uint64_t t = 1000000 + 20000 * static_cast<uint64_t>(i);
    w.Data(att, Pack(t) + Pack(1.0f) + Pack(0.0f) + Pack(0.0f) + Pack(0.0f));
    if (i == n) break;
    const double z = 1.0 - (2.0 * i + 1.0) / n, rho = std::sqrt(1.0 - z * z), phi = 2.39996322972865332 * i;
    raw.emplace_back(K * Eigen::Vector3d(0.5 * rho * std::cos(phi), 0.5 * rho * std::sin(phi), 0.5 * z) + b);
    const Eigen::Vector3f c = (R * S * (raw.back() - off)).cast<float>();
    w.Data(vm, Pack(t) + Pack<uint32_t>(4242) + Pack(c(0)) + Pack(c(1)) + Pack(c(2)));
  }
  const fs::path d = fs::temp_directory_path() / ("hexsim_calulg_" + std::to_string(::getpid()));
  fs::create_directories(d);
  std::ofstream(d / "px4.ulg", std::ios::binary) << w.bytes();
  const std::string cmd = std::string(HEXSIM_BINARY) + " calibrate " + (d / "px4.ulg").string() + " --out " +
                          (d / "c.yaml").string() + " >" + (d / "o").string() + " 2>&1";
  const int raw_rc = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(raw_rc));
  std::stringstream out;
  out << std::ifstream(d / "o").rdbuf();
  ASSERT_EQ(WEXITSTATUS(raw_rc), 0) << out.str();
  EXPECT_NE(out.str().find("rebuilt"), std::string::npos) << out.str();
  std::ifstream rep(d / "c.report.json");
  const nlohmann::json j = nlohmann::json::parse(rep);
  hexsim::magnetics::ParamList px4;
  for (const auto& [name, value] : j["px4_params"].items()) px4.emplace_back(name, value.get<double>());
  ASSERT_FALSE(px4.empty());
  EXPECT_EQ(px4.front().first.rfind("CAL_MAG2_", 0), 0u) << px4.front().first;
  // Absolute: the offset is the true hard iron, not its difference from the stale one.
  EXPECT_NEAR(j["px4_params"]["CAL_MAG2_XOFF"].get<double>(), b(0), 1e-3);
  EXPECT_NEAR(j["px4_params"]["CAL_MAG2_YOFF"].get<double>(), b(1), 1e-3);
  EXPECT_NEAR(j["px4_params"]["CAL_MAG2_ZOFF"].get<double>(), b(2), 1e-3);
  // Applied the way PX4 does to the raw readings: one norm, within 0.2 %.
  double lo = INFINITY, hi = 0.0;
  for (const auto& r : raw) {
    const double m = hexsim::magnetics::ApplyPx4Compass(px4, 2, r).norm();
    lo = std::min(lo, m);
    hi = std::max(hi, m);
  }
  EXPECT_LT((hi - lo) / hi, 2e-3) << lo << " .. " << hi;
  fs::remove_all(d);
}

}  // namespace
