// `hexsim serve-px4` ended by a signal (CONTRACTS' exit-code table: 130 for SIGINT/SIGTERM):
//   - GIVEN a client flying in lockstep, WHEN the server gets SIGINT (or SIGTERM), THEN it closes
//     the connection, writes a complete flight log (log.csv, log.meta.json, summary.json, the meta's
//     bridge.end_reason "interrupted"), says so on stderr and exits 130;
//   - GIVEN no client yet, WHEN the signal comes, THEN it exits 130 and writes nothing.
// The server runs as the real command (fork + exec of build/apps/hexsim); the client is a few
// lines of C++ on the bridge's own framing.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "hexsim/bridge/messages.h"
#include "hexsim/bridge/sim_messages.h"
#include "hexsim/logs/flight_log.h"

namespace fs = std::filesystem;

namespace hexsim::bridge {
namespace {

std::string ReadAll(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

struct Server {
  pid_t pid = -1;
  int port = 0;
  fs::path err;
};

// Starts `hexsim serve-px4 --vehicle quad_x --port 0 --out DIR/flight` and waits for its port.
Server StartServer(const fs::path& dir) {
  fs::remove_all(dir);
  fs::create_directories(dir);
  Server s;
  s.err = dir / "server.err";
  s.pid = ::fork();
  if (s.pid == 0) {
    std::freopen(s.err.c_str(), "w", stderr);
    std::freopen((dir / "server.out").c_str(), "w", stdout);
    const std::string hexsim = std::string(HEXSIM_BINARY_DIR) + "/apps/hexsim";
    const std::string out = (dir / "flight").string();
    ::execl(hexsim.c_str(), hexsim.c_str(), "serve-px4", "--vehicle", "quad_x", "--port", "0", "--accept-timeout",
            "60", "--out", out.c_str(), static_cast<char*>(nullptr));
    std::_Exit(127);
  }
  for (int i = 0; i < 600 && s.port == 0; ++i) {  // up to 60 s for the server to listen
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const std::string text = ReadAll(s.err);
    const size_t at = text.find("listening on 127.0.0.1:");
    if (at != std::string::npos) s.port = std::atoi(text.c_str() + at + 23);
  }
  return s;
}

int ExitCode(pid_t pid) {
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

int Connect(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  inet_pton(AF_INET, "127.0.0.1", &a.sin_addr);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0) return fd;
  ::close(fd);
  return -1;
}

// Reads what the server sent and answers every HIL_SENSOR id 0 in it with HIL_ACTUATOR_CONTROLS of
// its time_usec, as PX4 does (samples paced before lockstep engaged are answered too, stale); the
// number answered, -1 when the server closed the connection.
int AnswerSensors(int fd, FrameParser* p, FrameEncoder* enc) {
  uint8_t buf[4096];
  const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
  if (n <= 0) return -1;
  HilActuatorControls act;
  act.mode = 129;  // armed
  act.controls = {0.2f, 0.2f, 0.2f, 0.2f};
  std::vector<uint8_t> bytes;
  int answered = 0;
  p->Feed(buf, static_cast<size_t>(n), [&](const Frame& f) {
    if (f.msgid != kMsgHilSensor || UnpackHilSensor(f).id != 0) return;
    act.time_usec = UnpackHilSensor(f).time_usec;
    EncodeMessage(enc, kMsgHilActuatorControls, act, &bytes);
    ++answered;
  });
  if (!bytes.empty() && ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(bytes.size())) {
    return -1;
  }
  return answered;
}

class ServeSignal : public ::testing::TestWithParam<int> {};

TEST_P(ServeSignal, DuringAFlightExits130WithTheLogClosed) {
  const int sig = GetParam();
  const fs::path dir = fs::path(HEXSIM_BINARY_DIR) / "bridge" / ("signal_flight_" + std::to_string(sig));
  const Server server = StartServer(dir);
  ASSERT_GT(server.port, 0) << ReadAll(server.err);
  const int fd = Connect(server.port);
  ASSERT_GE(fd, 0);
  FrameParser parser;
  FrameEncoder enc(1, 1);
  int answered = 0;
  while (answered < 400) {  // 1 s of lockstep at the 400 Hz IMU
    const int n = AnswerSensors(fd, &parser, &enc);
    ASSERT_GE(n, 0) << ReadAll(server.err);
    answered += n;
  }
  // The server now waits for the next answer or computes the next step; the signal ends the flight.
  ASSERT_EQ(::kill(server.pid, sig), 0);
  while (AnswerSensors(fd, &parser, &enc) >= 0) {  // keeps answering until the server closes
  }
  ::close(fd);
  const int rc = ExitCode(server.pid);
  const std::string err_text = ReadAll(server.err);
  EXPECT_EQ(rc, 130) << err_text;
  EXPECT_NE(err_text.find(std::string("interrupted (") + (sig == SIGINT ? "SIGINT" : "SIGTERM") +
                          "): flight log closed cleanly"),
            std::string::npos)
      << err_text;
  auto log = logs::ReadFlightLog((dir / "flight/log.csv").string());
  ASSERT_TRUE(log.ok()) << log.status().message();
  const auto& ts = log->Column("t_s");
  ASSERT_FALSE(ts.empty());
  // Logged up to the signal: ~1 s flown before it (and the few steps answered while it arrived).
  EXPECT_GT(ts.back(), 0.9);
  EXPECT_LT(ts.back(), 3.0);
  const auto meta = nlohmann::json::parse(ReadAll(dir / "flight/log.meta.json"));
  EXPECT_EQ(meta["bridge"]["end_reason"], "interrupted");
  EXPECT_GE(meta["bridge"]["actuator_messages"].get<int>(), 400);
  const auto summary = nlohmann::json::parse(ReadAll(dir / "flight/summary.json"));
  EXPECT_EQ(summary["status"], "completed");
}

TEST_P(ServeSignal, BeforeAClientExits130AndWritesNothing) {
  const int sig = GetParam();
  const fs::path dir = fs::path(HEXSIM_BINARY_DIR) / "bridge" / ("signal_idle_" + std::to_string(sig));
  const Server server = StartServer(dir);
  ASSERT_GT(server.port, 0) << ReadAll(server.err);
  ASSERT_EQ(::kill(server.pid, sig), 0);
  const int rc = ExitCode(server.pid);
  const std::string err_text = ReadAll(server.err);
  EXPECT_EQ(rc, 130) << err_text;
  EXPECT_NE(err_text.find("before a client connected: nothing written"), std::string::npos) << err_text;
  EXPECT_FALSE(fs::exists(dir / "flight"));
}

INSTANTIATE_TEST_SUITE_P(SigintAndSigterm, ServeSignal, ::testing::Values(SIGINT, SIGTERM),
                         [](const ::testing::TestParamInfo<int>& i) { return i.param == SIGINT ? "SIGINT" : "SIGTERM"; });

}  // namespace
}  // namespace hexsim::bridge
