// The PX4 bridge's costs beside the physics they serve (bench/README.md has the figures):
//   BM_EncodeDecodeExchange  one lockstep exchange in-process: HIL_ACTUATOR_CONTROLS encoded and
//                            parsed, HIL_SENSOR built from readings, encoded and parsed (target <= 5 us)
//   BM_PhysicsImuPeriod      the physics of one IMU period (quad_x hover, 400 Hz IMU on 1 kHz physics:
//                            2.5 steps on average) without the bridge: the same steps as one exchange
//   BM_LoopbackPingPong      the socket alone: one send/recv round trip between two threads over
//                            loopback TCP (TCP_NODELAY, blocking recv) with the exchange's sizes,
//                            no physics, no bridge: the floor of any exchange on this host
//   BM_LoopbackLockstep      the whole exchange over loopback TCP with a C++ client answering each
//                            HIL_SENSOR, physics included (target with the peer <= 50 us)
#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <ctime>
#include <thread>
#include <utility>

#include <benchmark/benchmark.h>

#include "hexsim/bridge/messages.h"
#include "hexsim/bridge/server.h"
#include "hexsim/bridge/sim_messages.h"
#include "hexsim/sim/run_config.h"

namespace hexsim::bridge {
namespace {

sim::RunSetup QuadSetup(double duration_s) {
  sim::RunRequest rq;
  rq.vehicle = "quad_x";
  rq.estimator = "truth";
  rq.duration_s = duration_s;
  sim::RunSetup setup = sim::LoadRunSetup(rq).value();
  setup.mission = control::Mission{};
  setup.mission.resolved = true;
  setup.options.write_log = false;
  return setup;
}

double ProcessCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

void BM_EncodeDecodeExchange(benchmark::State& state) {
  FrameEncoder client(1, 1), server(1, 200);
  FrameParser at_server, at_client;
  vehicle::SensorReadings rd;
  rd.mag_uT.resize(1);
  rd.accel_mps2.value = {0.1, -0.2, -9.8};
  rd.mag_uT[0].value = {21.0, -3.0, 45.0};
  sim::WorldParams world;
  HilActuatorControls act;
  act.mode = 129;
  act.controls = {0.34f, 0.35f, 0.33f, 0.34f};
  std::vector<uint8_t> bytes;
  bytes.reserve(512);
  double t = 0.0;
  float sink = 0.0f;
  for (auto _ : state) {
    bytes.clear();
    act.time_usec = TimeUsec(t);
    EncodeMessage(&client, kMsgHilActuatorControls, act, &bytes);
    at_server.Feed(bytes.data(), bytes.size(), [&](const Frame& f) { sink += UnpackHilActuatorControls(f).controls[0]; });
    bytes.clear();
    EncodeMessage(&server, kMsgHilSensor, MakeHilSensor(t, rd, world, true, true), &bytes);
    at_client.Feed(bytes.data(), bytes.size(), [&](const Frame& f) { sink += UnpackHilSensor(f).xmag; });
    t += 0.0025;
  }
  benchmark::DoNotOptimize(sink);
}
BENCHMARK(BM_EncodeDecodeExchange);

void BM_PhysicsImuPeriod(benchmark::State& state) {
  uint64_t hooks = 0;
  sim::Plugins plugins;
  plugins.command_hook = [&hooks](double, const control::NavState&, std::vector<double>* c) {
    std::fill(c->begin(), c->end(), 0.345);
    ++hooks;
  };
  auto sim = sim::Simulation::Create(QuadSetup(3600.0), std::move(plugins)).value();
  for (auto _ : state) {
    // One IMU period, as one lockstep exchange: physics steps up to the next command hook (2 or 3
    // of the 1 kHz steps per 400 Hz sample).
    const uint64_t before = hooks;
    while (hooks == before) sim->Step();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));  // items = IMU periods
}
BENCHMARK(BM_PhysicsImuPeriod)->UseRealTime();

// A connected loopback TCP pair (TCP_NODELAY on both ends); {-1, -1} when the host refuses.
std::pair<int, int> LoopbackPair() {
  const int lfd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  inet_pton(AF_INET, "127.0.0.1", &a.sin_addr);
  socklen_t len = sizeof a;
  int c = -1, s = -1;
  if (::bind(lfd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 && ::listen(lfd, 1) == 0 &&
      ::getsockname(lfd, reinterpret_cast<sockaddr*>(&a), &len) == 0) {
    c = ::socket(AF_INET, SOCK_STREAM, 0);
    if (::connect(c, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0) s = ::accept(lfd, nullptr, nullptr);
  }
  ::close(lfd);
  if (s < 0) {
    if (c >= 0) ::close(c);
    return {-1, -1};
  }
  const int one = 1;
  ::setsockopt(c, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  ::setsockopt(s, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  return {s, c};
}

// Receives exactly n bytes; false when the peer closed.
bool RecvAll(int fd, uint8_t* buf, size_t n) {
  for (size_t at = 0; at < n;) {
    const ssize_t r = ::recv(fd, buf + at, n - at, 0);
    if (r <= 0) return false;
    at += static_cast<size_t>(r);
  }
  return true;
}

void BM_LoopbackPingPong(benchmark::State& state) {
  constexpr size_t kSensorBytes = 12 + 65;    // HIL_SENSOR id 0 framed (no trailing zeros cut)
  constexpr size_t kActuatorBytes = 12 + 81;  // HIL_ACTUATOR_CONTROLS framed
  const auto [s, c] = LoopbackPair();
  if (s < 0) {
    state.SkipWithError("no loopback TCP pair");
    return;
  }
  std::thread answerer([c = c] {
    uint8_t in[kSensorBytes], reply[kActuatorBytes] = {};
    while (RecvAll(c, in, sizeof in)) {
      if (::send(c, reply, sizeof reply, MSG_NOSIGNAL) != static_cast<ssize_t>(sizeof reply)) break;
    }
  });
  uint8_t out[kSensorBytes] = {}, in[kActuatorBytes];
  for (auto _ : state) {
    if (::send(s, out, sizeof out, MSG_NOSIGNAL) != static_cast<ssize_t>(sizeof out) || !RecvAll(s, in, sizeof in)) {
      state.SkipWithError("loopback pair closed");
      break;
    }
  }
  ::shutdown(s, SHUT_RDWR);
  answerer.join();
  ::close(s);
  ::close(c);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));  // items = round trips
}
BENCHMARK(BM_LoopbackPingPong)->UseRealTime();

void BM_LoopbackLockstep(benchmark::State& state) {
  std::atomic<int> port{0};
  ServeOptions opt;
  opt.port = 0;
  opt.accept_timeout_s = 30;
  opt.log = [&port](const std::string& line) {
    const size_t at = line.find("listening on 127.0.0.1:");
    if (at != std::string::npos) port = std::atoi(line.c_str() + at + 23);
  };
  std::thread server([&] { (void)ServePx4(QuadSetup(3600.0), opt); });
  while (port == 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port.load()));
  inet_pton(AF_INET, "127.0.0.1", &a.sin_addr);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    state.SkipWithError("connect to the bridge failed");
    ::close(fd);
    server.join();  // the server gives up after accept_timeout_s
    return;
  }
  const int one = 1;
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  FrameParser parser;
  FrameEncoder enc(1, 1);
  HilActuatorControls act;
  act.mode = 129;
  act.controls = {0.345f, 0.345f, 0.345f, 0.345f};
  std::vector<uint8_t> out;
  uint8_t buf[4096];
  const double cpu0 = ProcessCpuSeconds();
  for (auto _ : state) {
    uint64_t t = 0;
    while (t == 0) {
      const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
      if (n <= 0) break;
      parser.Feed(buf, static_cast<size_t>(n), [&](const Frame& f) {
        // The newest sample: the server waits on it (paced samples can arrive in a batch).
        if (f.msgid == kMsgHilSensor && UnpackHilSensor(f).id == 0) t = std::max(t, UnpackHilSensor(f).time_usec);
      });
    }
    out.clear();
    act.time_usec = t;
    EncodeMessage(&enc, kMsgHilActuatorControls, act, &out);
    ::send(fd, out.data(), out.size(), MSG_NOSIGNAL);
  }
  // Both threads' CPU (server with its physics, and this client) per exchange: the wall time on a
  // shared host mostly measures who else runs; this is what the exchange costs.
  state.counters["process_cpu_us"] =
      (ProcessCpuSeconds() - cpu0) * 1e6 / static_cast<double>(std::max<int64_t>(1, state.iterations()));
  ::close(fd);
  server.join();
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));  // items = IMU periods
}
BENCHMARK(BM_LoopbackLockstep)->UseRealTime();

}  // namespace
}  // namespace hexsim::bridge

BENCHMARK_MAIN();
