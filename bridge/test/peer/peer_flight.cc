// The independent peer test: `hexsim serve-px4 --vehicle quad_x` flown by a node-mavlink client
// (peer.mjs: its own parser, CRC and CRC_EXTRA tables) that holds attitude and altitude on the
// decoded sensors only and answers each HIL_SENSOR in lockstep. Checks, against hexsim's log:
//   - GIVEN no wind, WHEN the peer takes off to 3 m, THEN the height stays within +-0.5 m of it
//     for the 30 s hold;
//   - every decoded compass sample equals hexsim's logged sample (uT * 0.01) to float32 precision;
//   - the decoded internal compass (mag2) moves with the motor currents by the field the magnetic
//     model predicts (slope 1 within 5 % against the model's current-driven field);
//   - no step skipped or repeated: time_usec strictly increasing, at most one IMU period apart,
//     every HIL_SENSOR answered;
//   - BATTERY_STATUS reaches a UDP listener as system 1, component 180 (MAV_COMP_ID_BATTERY).
// Skips (saying so) only when node is not installed; the npm fixture (bridge_peer_npm) installs
// node-mavlink from bridge/test/peer/package-lock.json into the build tree.
#include <netinet/in.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "hexsim/logs/flight_log.h"
#include "hexsim/vehicle/sensors.h"
#include "hexsim/vehicle/vehicle_io.h"

namespace fs = std::filesystem;

namespace hexsim::bridge {
namespace {

bool NodeInstalled() { return std::system("node --version > /dev/null 2>&1") == 0; }

int FreeUdpPort() {
  // 0 when no port could be had: the flight's --battery-udp then fails loudly (a test failure).
  const int s = ::socket(AF_INET, SOCK_DGRAM, 0);
  if (s < 0) return 0;
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  const bool ok = ::bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
                  ::getsockname(s, reinterpret_cast<sockaddr*>(&a), &len) == 0;
  ::close(s);
  return ok ? ntohs(a.sin_port) : 0;
}

std::string ReadAll(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

class PeerFlight : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!NodeInstalled()) return;
    dir_ = fs::path(HEXSIM_BINARY_DIR) / "bridge" / "peer_flight";
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    const fs::path err = dir_ / "server.err";
    const pid_t pid = ::fork();
    if (pid == 0) {
      std::freopen(err.c_str(), "w", stderr);
      std::freopen((dir_ / "server.out").c_str(), "w", stdout);
      const std::string hexsim = std::string(HEXSIM_BINARY_DIR) + "/apps/hexsim";
      const std::string out = (dir_ / "flight").string();
      const std::string udp = "127.0.0.1:" + std::to_string(battery_port_);
      ::execl(hexsim.c_str(), hexsim.c_str(), "serve-px4", "--vehicle", "quad_x", "--port", "0", "--accept-timeout",
              "60", "--battery-udp", udp.c_str(), "--out", out.c_str(), static_cast<char*>(nullptr));
      std::_Exit(127);
    }
    int port = 0;
    for (int i = 0; i < 600 && port == 0; ++i) {  // up to 60 s for the server to listen
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      const std::string text = ReadAll(err);
      const size_t at = text.find("listening on 127.0.0.1:");
      if (at != std::string::npos) port = std::atoi(text.c_str() + at + 23);
    }
    const std::string peer_dir = std::string(HEXSIM_BINARY_DIR) + "/bridge/peer";
    std::ostringstream cmd;
    cmd << "cd " << peer_dir << " && node peer.mjs --port " << port << " --airframe " << HEXSIM_SOURCE_DIR
        << "/worlds/px4/22001_hexsim_quad_x --out " << (dir_ / "peer.json").string() << " --battery-udp-port "
        << battery_port_ << " > " << (dir_ / "peer.log").string() << " 2>&1";
    const auto t0 = std::chrono::steady_clock::now();
    peer_rc_ = port > 0 ? std::system(cmd.str().c_str()) : -1;
    peer_wall_s_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    int status = 0;
    ::waitpid(pid, &status, 0);
    server_rc_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    rusage children{};  // node and hexsim, both waited for: the flight's CPU, whatever else runs
    ::getrusage(RUSAGE_CHILDREN, &children);
    peer_cpu_s_ = static_cast<double>(children.ru_utime.tv_sec + children.ru_stime.tv_sec) +
                  1e-6 * static_cast<double>(children.ru_utime.tv_usec + children.ru_stime.tv_usec);
  }

  void SetUp() override {
    if (!NodeInstalled()) GTEST_SKIP() << "node is not installed: the node-mavlink peer test cannot run";
    ASSERT_TRUE(fs::exists(fs::path(HEXSIM_BINARY_DIR) / "bridge/peer/node_modules/node-mavlink"))
        << "node-mavlink missing: run the fixture (ctest -R bridge_peer)";
    ASSERT_EQ(peer_rc_, 0) << ReadAll(dir_ / "peer.log") << ReadAll(dir_ / "server.err");
    ASSERT_EQ(server_rc_, 0) << ReadAll(dir_ / "server.err");
    peer_ = nlohmann::json::parse(ReadAll(dir_ / "peer.json"));
    auto log = logs::ReadFlightLog((dir_ / "flight/log.csv").string());
    ASSERT_TRUE(log.ok()) << log.status().message();
    log_ = std::move(*log);
    meta_ = nlohmann::json::parse(ReadAll(dir_ / "flight/log.meta.json"));
  }

  static inline fs::path dir_;
  static inline int peer_rc_ = -1, server_rc_ = -1;
  static inline int battery_port_ = FreeUdpPort();
  static inline double peer_wall_s_ = 0.0, peer_cpu_s_ = 0.0;
  nlohmann::json peer_, meta_;
  logs::FlightLog log_;
};

TEST_F(PeerFlight, TakesOffAndHoldsAltitudeWithinHalfAMetre) {
  const auto& t = log_.Column("t_s");
  const auto& d = log_.Column("pos_D_m");
  const double window_lo = peer_["hold_window_s"][0], window_hi = peer_["hold_window_s"][1];
  ASSERT_GE(window_hi - window_lo, 30.0);
  size_t n = 0;
  double worst = 0.0;
  for (size_t i = 0; i < t.size(); ++i) {
    if (t[i] < window_lo || t[i] > window_hi) continue;
    worst = std::max(worst, std::abs((d[0] - d[i]) - 3.0));  // height above the start vs the 3 m setpoint
    ++n;
  }
  EXPECT_GE(n, 3000u);
  EXPECT_LE(worst, 0.5);
  std::printf("peer hover: worst height error %.3f m over %.0f s; %.1f s wall (%.1f s CPU, node and hexsim) for "
              "%.1f s simulated\n",
              worst, window_hi - window_lo, peer_wall_s_, peer_cpu_s_, t.back());
  // Target: the 30 s hover under 10 s wall (bench/README.md: this line over 10 runs on the shared
  // host); a loaded CI host gets 4x.
  EXPECT_LT(peer_wall_s_, 10.0 * 4);
}

TEST_F(PeerFlight, NoStepSkippedOrRepeated) {
  const auto& times = peer_["sensor_time_usec"];
  ASSERT_GT(times.size(), 15000u);
  const double imu_period_us = 1e6 / 400.0, physics_us = 1000.0;
  const double max_gap_us = std::ceil(imu_period_us / physics_us) * physics_us;
  for (size_t i = 1; i < times.size(); ++i) {
    const int64_t gap = times[i].get<int64_t>() - times[i - 1].get<int64_t>();
    ASSERT_GT(gap, 0) << "repeated at " << i;
    ASSERT_LE(gap, max_gap_us) << "skipped at " << i;
  }
  EXPECT_EQ(peer_["answered"].get<size_t>(), times.size());
  const auto& b = meta_["bridge"];
  EXPECT_EQ(b["sensor_messages"].get<size_t>(), times.size() + 1);  // the last one met a closed socket
  EXPECT_EQ(b["actuator_messages"].get<size_t>(), times.size());
  // Answers to samples sent at wall-clock pace before the first answer arrived; none once in lockstep.
  EXPECT_LE(b["stale_actuator_messages"].get<int>(), b["paced_sensor_messages"].get<int>());
  EXPECT_LE(b["paced_sensor_messages"].get<int>(), 400);  // the peer answered within 1 s of connecting
  EXPECT_EQ(b["bad_crc"].get<int>(), 0);
  EXPECT_EQ(b["lost_frames"].get<int>(), 0);
  EXPECT_EQ(peer_["parser_invalid_packets"].get<int>(), 0);
}

TEST_F(PeerFlight, DecodedCompassEqualsHexsimsSampleToFloat32) {
  // Decoded samples by (id, time_usec).
  std::map<std::pair<int, int64_t>, std::array<double, 3>> decoded;
  for (const auto& m : peer_["mags"]) decoded[{m[1].get<int>(), m[0].get<int64_t>()}] = {m[2], m[3], m[4]};
  size_t compared = 0;
  for (int id = 0; id < 2; ++id) {
    const std::string p = id == 0 ? "mag" : "mag2";
    const auto& ts = log_.Column(p + "_t_s");
    const auto& x = log_.Column(p + "_x_uT");
    const auto& y = log_.Column(p + "_y_uT");
    const auto& z = log_.Column(p + "_z_uT");
    for (size_t i = 0; i < ts.size(); ++i) {
      if (!std::isfinite(ts[i])) continue;
      // The sample went out with the first IMU message at or after its time.
      auto it = decoded.lower_bound({id, static_cast<int64_t>(std::llround(ts[i] * 1e6)) + 1000000});
      if (it == decoded.end() || it->first.first != id) continue;
      const std::array<double, 3>& got = it->second;
      ASSERT_EQ(static_cast<float>(got[0]), static_cast<float>(x[i] * 0.01)) << p << " at " << ts[i];
      ASSERT_EQ(static_cast<float>(got[1]), static_cast<float>(y[i] * 0.01)) << p << " at " << ts[i];
      ASSERT_EQ(static_cast<float>(got[2]), static_cast<float>(z[i] * 0.01)) << p << " at " << ts[i];
      ++compared;
    }
  }
  EXPECT_GT(compared, 5000u);
}

// mag2 is the internal compass by the power wiring (~0.3-0.4 uT/A). Remove the model's
// zero-current reading (Earth field through hard/soft iron at the true attitude); what is left of the
// decoded sample must follow the model's current-driven part with slope 1.
TEST_F(PeerFlight, DecodedCompassMovesWithMotorCurrentAsTheModelPredicts) {
  auto v = vehicle::LoadVehicleFile(std::string(HEXSIM_SOURCE_DIR) + "/worlds/vehicles/quad_x.yaml");
  ASSERT_TRUE(v.ok());
  const vehicle::CompassParams& c = v->compasses[1];
  const Eigen::Vector3d B_N(meta_["earth_field_N_uT"][0], meta_["earth_field_N_uT"][1], meta_["earth_field_N_uT"][2]);
  const auto& t = log_.Column("t_s");
  const auto& mt = log_.Column("mag2_t_s");
  std::vector<double> model, observed;
  double model_lo = 1e9, model_hi = -1e9;
  for (size_t i = 0; i < t.size(); ++i) {
    if (!(std::abs(t[i] - mt[i]) < 1e-9)) continue;  // rows whose sample was taken at the row's instant
    const Eigen::Quaterniond q(log_.Column("q_w")[i], log_.Column("q_x")[i], log_.Column("q_y")[i],
                               log_.Column("q_z")[i]);
    magnetics::Currents on, off;
    on.battery_A = log_.Column("current_A")[i];
    for (int m = 1; m <= 4; ++m) on.motor_A.push_back(log_.Column("motor_" + std::to_string(m) + "_A")[i]);
    off.battery_A = v->avionics_current_A;
    off.motor_A.assign(4, 0.0);
    const Eigen::Vector3d full = vehicle::CompassNoiseFree_uT(c, v->wiring, q, B_N, on);
    const Eigen::Vector3d zero = vehicle::CompassNoiseFree_uT(c, v->wiring, q, B_N, off);
    const Eigen::Vector3d got(log_.Column("mag2_x_uT")[i], log_.Column("mag2_y_uT")[i], log_.Column("mag2_z_uT")[i]);
    for (int a = 0; a < 3; ++a) {
      model.push_back(full(a) - zero(a));
      observed.push_back(got(a) - zero(a));
    }
    model_lo = std::min(model_lo, (full - zero).norm());
    model_hi = std::max(model_hi, (full - zero).norm());
  }
  ASSERT_GT(model.size(), 1500u);
  ASSERT_GT(model_hi - model_lo, 2.0) << "the flight must span ground (motors off) and hover currents";
  // Slope of observed on model with a per-axis offset (the compass bias): centre each axis.
  double sxy = 0, sxx = 0;
  for (int a = 0; a < 3; ++a) {
    double mx = 0, my = 0, n = 0;
    for (size_t k = a; k < model.size(); k += 3) mx += model[k], my += observed[k], ++n;
    mx /= n, my /= n;
    for (size_t k = a; k < model.size(); k += 3) sxy += (model[k] - mx) * (observed[k] - my), sxx += (model[k] - mx) * (model[k] - mx);
  }
  const double slope = sxy / sxx;
  std::printf("mag2 current-driven field: model spans %.2f..%.2f uT, decoded/model slope %.3f\n", model_lo, model_hi,
              slope);
  EXPECT_NEAR(slope, 1.0, 0.05);
}

TEST_F(PeerFlight, BatteryStatusReachesTheUdpListenerAsTheBatteryComponent) {
  const auto& udp = peer_["udp_battery"];
  ASSERT_GT(udp.size(), 100u);
  const auto& last = udp[udp.size() - 1];
  EXPECT_EQ(last[0].get<int>(), 1);
  EXPECT_EQ(last[1].get<int>(), 180);
  const double V = last[2].get<double>() * 1e-3, A = last[3].get<double>() * 1e-2;
  EXPECT_GT(V, 14.0);  // a 4S pack in flight
  EXPECT_GT(A, 5.0);   // hover current of a 1.5 kg quad
}

}  // namespace
}  // namespace hexsim::bridge
