// The lockstep server against a scripted client: bad network input is counted and ignored, a second
// client is refused, a disconnect mid-frame ends the flight cleanly with the log complete.
#include "hexsim/bridge/server.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>

#include <gtest/gtest.h>

#include "hexsim/bridge/messages.h"
#include "hexsim/bridge/sim_messages.h"
#include "hexsim/sim/run_config.h"

namespace hexsim::bridge {
namespace {

sim::RunSetup QuadSetup() {
  sim::RunRequest rq;
  rq.mission = "square";
  rq.vehicle = "quad_x";
  rq.estimator = "truth";
  auto setup = sim::LoadRunSetup(rq);
  EXPECT_TRUE(setup.ok()) << setup.status().message();
  setup->mission = control::Mission{};
  setup->mission.resolved = true;
  return *setup;
}

int Connect(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  inet_pton(AF_INET, "127.0.0.1", &a.sin_addr);
  return ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 ? fd : -1;
}

void SendBytes(int fd, const std::vector<uint8_t>& b) { ASSERT_EQ(::send(fd, b.data(), b.size(), MSG_NOSIGNAL), static_cast<ssize_t>(b.size())); }

// ServePx4 on a free port in a thread. The destructor joins it, also after a failed ASSERT returned
// early (the server then ends on its idle timeout) instead of aborting on a joinable thread.
class ServerThread {
 public:
  explicit ServerThread(double idle_timeout_s) {
    opt_.port = 0;
    opt_.accept_timeout_s = 30;
    opt_.idle_timeout_s = idle_timeout_s;
    opt_.log = [this](const std::string& line) {
      const size_t at = line.find("listening on 127.0.0.1:");
      if (at != std::string::npos) port_ = std::atoi(line.c_str() + at + 23);
    };
    thread_ = std::thread([this] { result_ = ServePx4(QuadSetup(), opt_); });
    while (port_ == 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ServerThread(const ServerThread&) = delete;
  ServerThread& operator=(const ServerThread&) = delete;
  ~ServerThread() { Join(); }
  int port() const { return port_; }
  void Join() {
    if (thread_.joinable()) thread_.join();
  }
  // After Join().
  const Result<ServeResult>& result() const { return result_; }

 private:
  ServeOptions opt_;
  std::atomic<int> port_{0};
  Result<ServeResult> result_ = Status::BadInput("not run");
  std::thread thread_;
};

// Reads what has arrived until it holds a HIL_SENSOR id 0; returns the newest one's time_usec, the
// sample the server waits on (0: connection closed). Samples paced before lockstep engaged can wait
// in the socket in a batch: answering the oldest of a batch would leave the server waiting on the
// newest, already read, for ever (idle_timeout_s). PX4 stamps its outputs with the newest time too.
uint64_t NextSensorTime(int fd, FrameParser* p) {
  uint8_t buf[65536];
  uint64_t t = 0;
  while (t == 0) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) return 0;
    p->Feed(buf, static_cast<size_t>(n), [&](const Frame& f) {
      if (f.msgid == kMsgHilSensor && UnpackHilSensor(f).id == 0) t = std::max(t, UnpackHilSensor(f).time_usec);
    });
  }
  return t;
}

// Armed outputs (0.3 on each motor) stamped t, as the scripted client sends them.
HilActuatorControls Outputs(uint64_t t) {
  HilActuatorControls act;
  act.time_usec = t;
  act.mode = 129;
  act.controls = {0.3f, 0.3f, 0.3f, 0.3f};
  return act;
}

// Answers the sample at t and returns the next sample's time_usec (0: connection closed).
uint64_t AnswerThenNext(int fd, FrameEncoder* enc, FrameParser* p, uint64_t t) {
  std::vector<uint8_t> bytes;
  EncodeMessage(enc, kMsgHilActuatorControls, Outputs(t), &bytes);
  if (::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(bytes.size())) return 0;
  return NextSensorTime(fd, p);
}

TEST(ServePx4, BadInputIsIgnoredSecondClientRefusedDisconnectEndsTheFlightCleanly) {
  ServerThread server(5.0);  // a client that answers a stale sample waits this long, then fails
  const int port = server.port();
  const int fd = Connect(port);
  ASSERT_GE(fd, 0);
  FrameParser parser;
  FrameEncoder enc(1, 1);
  std::vector<uint8_t> good, bad_crc, unknown, signed_frame, garbage = {0xFD, 0x00, 0xFD, 0x51, 0x01, 0x42};
  uint64_t t = NextSensorTime(fd, &parser);
  ASSERT_GT(t, 0u);
  // PX4 boots on the paced sensor stream: a backlog of ~40 samples is waiting when lockstep engages.
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  const HilActuatorControls act = Outputs(t);
  EncodeMessage(&enc, kMsgHilActuatorControls, act, &bad_crc);
  bad_crc[20] ^= 0x55;
  EncodeMessage(&enc, kMsgHeartbeat, Heartbeat{}, &unknown);
  unknown[7] = 0x21;  // id 33: not one the server knows
  EncodeMessage(&enc, kMsgHilActuatorControls, act, &signed_frame);
  signed_frame[2] = 1;
  for (auto* b : {&garbage, &bad_crc, &unknown, &signed_frame}) SendBytes(fd, *b);
  const int second = Connect(port);  // refused: accepted and closed at once
  ASSERT_GE(second, 0);
  for (int step = 0; step < 200; ++step) {
    t = AnswerThenNext(fd, &enc, &parser, t);
    ASSERT_GT(t, 0u);
  }
  uint8_t byte = 0;
  EXPECT_EQ(::recv(second, &byte, 1, 0), 0) << "the second client must be closed";
  ::close(second);
  EncodeMessage(&enc, kMsgHilActuatorControls, act, &good);
  good.resize(good.size() / 2);  // half a frame, then gone
  SendBytes(fd, good);
  ::close(fd);
  server.Join();
  const Result<ServeResult>& result = server.result();
  ASSERT_TRUE(result.ok()) << result.status().message();
  EXPECT_EQ(result->end_reason, "client disconnected");
  const ServeStats& s = result->stats;
  EXPECT_EQ(s.refused_clients, 1u);
  EXPECT_GE(s.parser.bad_crc, 1u);
  EXPECT_GE(s.parser.unknown_id, 1u);
  EXPECT_GE(s.parser.incompatible, 1u);
  EXPECT_GE(s.actuator_messages, 200u);
  EXPECT_TRUE(result->run.status.ok());
  EXPECT_GE(result->run.log.rows(), 40u);  // ~0.5 s at 100 Hz, closed at the disconnect
  EXPECT_EQ(result->run.summary.status, sim::RunStatus::kCompleted);
  EXPECT_NE(result->run.summary.reason.find("client disconnected"), std::string::npos);
}

TEST(ServePx4, SecondClientIsRefusedWhileTheFirstIsSilentInLockstep) {
  ServerThread server(20.0);
  const int port = server.port();
  const int fd = Connect(port);
  ASSERT_GE(fd, 0);
  FrameParser parser;
  FrameEncoder enc(1, 1);
  uint64_t t = NextSensorTime(fd, &parser);
  for (int step = 0; step < 3 && t > 0; ++step) t = AnswerThenNext(fd, &enc, &parser, t);
  ASSERT_GT(t, 0u);
  // Silent now: lockstep engaged, the server waits on our answer; a second client is still refused.
  const int second = Connect(port);
  ASSERT_GE(second, 0);
  const timeval two_s{2, 0};
  ::setsockopt(second, SOL_SOCKET, SO_RCVTIMEO, &two_s, sizeof two_s);
  uint8_t byte = 0;
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(::recv(second, &byte, 1, 0), 0) << "the second client must be closed while the first is silent";
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 1.0);
  ::close(second);
  ::close(fd);
  server.Join();
  const Result<ServeResult>& result = server.result();
  ASSERT_TRUE(result.ok()) << result.status().message();
  EXPECT_EQ(result->stats.refused_clients, 1u);
  EXPECT_EQ(result->end_reason, "client disconnected");
}

TEST(ServePx4, NoClientWithinTheTimeoutIsAClearError) {
  ServeOptions opt;
  opt.port = 0;
  opt.accept_timeout_s = 0.2;
  auto r = ServePx4(QuadSetup(), opt);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("no client connected"), std::string::npos);
}

TEST(SimMessages, IsaAndUnits) {
  EXPECT_NEAR(IsaPressure_hPa(0.0), 1013.25, 1e-9);
  EXPECT_NEAR(IsaPressure_hPa(1000.0), 898.75, 0.1);  // ISA table: 898.76 hPa at 1000 m
  EXPECT_NEAR(IsaTemperature_C(1000.0), 8.5, 1e-9);
  EXPECT_EQ(TimeUsec(0.0025), 1002500u);
  EXPECT_DOUBLE_EQ(TimeSeconds(1002500u), 0.0025);
}

}  // namespace
}  // namespace hexsim::bridge
