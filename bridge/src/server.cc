// The lockstep TCP server of PX4's Simulator MAVLink API (server.h).
#include "hexsim/bridge/server.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <thread>

#include <fmt/format.h>

#include "hexsim/bridge/messages.h"
#include "hexsim/bridge/px4_frame.h"
#include "hexsim/bridge/sim_messages.h"

namespace hexsim::bridge {

namespace {

using Clock = std::chrono::steady_clock;

class Fd {
 public:
  explicit Fd(int fd = -1) : fd_(fd) {}
  ~Fd() { Reset(); }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  int get() const { return fd_; }
  void Reset(int fd = -1) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = fd;
  }

 private:
  int fd_;
};

Result<sockaddr_in> ParseAddress(const std::string& host, int port, const std::string& what) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  if (port < 0 || port > 65535 || inet_pton(AF_INET, host.c_str(), &a.sin_addr) != 1) {
    return Status::BadInput(fmt::format("{}: not an IPv4 address and port: {}:{}", what, host, port));
  }
  return a;
}

constexpr uint8_t kArmedFlag = 128;  // MAV_MODE_FLAG_SAFETY_ARMED
constexpr const char* kInterrupted = "interrupted";

struct Session {
  const ServeOptions& opt;
  Px4RotorMap map;
  Fd listen_fd, fd, udp_fd;
  sockaddr_in udp_to{};
  FrameParser parser;
  FrameEncoder enc{1, 200};
  FrameEncoder battery_enc{1, 180};  // MAV_COMP_ID_BATTERY: PX4's mavlink module takes it from system 1
  sim::Simulation* sim = nullptr;
  std::array<float, 16> controls{};
  bool got_first_outputs = false;
  uint64_t awaiting_usec = 0;
  bool answered = false;
  bool ended = false;
  std::string end_reason;
  double last_mag_t[2] = {std::nan(""), std::nan("")};
  double last_baro_t = std::nan(""), last_gps_t = std::nan("");
  double state_period_s = 0.02, battery_period_s = 0.02;
  double next_state_t = 0.0, next_battery_t = 0.0, next_heartbeat_t = 0.0;
  double consumed_mAh = 0.0, last_battery_t = 0.0;
  Clock::time_point wall0 = Clock::now();
  ServeStats stats;
  std::vector<uint8_t> out;

  explicit Session(const ServeOptions& o) : opt(o) {}

  void End(const std::string& why) {
    if (ended) return;
    ended = true;
    end_reason = why;
    opt.log("flight ended: " + why);
  }

  bool SendAll(const std::vector<uint8_t>& bytes) {
    size_t at = 0;
    while (at < bytes.size()) {
      const ssize_t n = ::send(fd.get(), bytes.data() + at, bytes.size() - at, MSG_NOSIGNAL);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        End(fmt::format("client disconnected (send: {})", std::strerror(errno)));
        return false;
      }
      at += static_cast<size_t>(n);
    }
    return true;
  }

  void OnFrame(const Frame& f) {
    switch (f.msgid) {
      case kMsgHilActuatorControls: {
        const HilActuatorControls m = UnpackHilActuatorControls(f);
        ++stats.actuator_messages;
        controls = m.controls;
        if (!(m.mode & kArmedFlag)) controls.fill(0.0f);  // PX4 sends zeros disarmed; enforce it
        got_first_outputs = true;
        if (m.time_usec >= awaiting_usec) {
          answered = true;
        } else {
          ++stats.stale_actuator_messages;
        }
        break;
      }
      case kMsgCommandLong: {
        const CommandLong c = UnpackCommandLong(f);
        if (c.command == kMavCmdSetMessageInterval) SetInterval(c.param[0], c.param[1]);
        break;
      }
      default:
        ++stats.ignored_messages;  // HEARTBEAT and anything else the simulator side does not act on
    }
  }

  void SetInterval(float msg_id, float interval_us) {
    double* period = msg_id == static_cast<float>(kMsgHilStateQuaternion) ? &state_period_s
                     : msg_id == static_cast<float>(kMsgBatteryStatus)    ? &battery_period_s
                                                                          : nullptr;
    if (period == nullptr || !std::isfinite(interval_us)) return;
    const double fallback = period == &state_period_s ? 1.0 / opt.hil_state_rate_hz : 1.0 / opt.battery_rate_hz;
    *period = interval_us < 0 ? -1.0 : interval_us == 0 ? fallback : std::max(1e-3, interval_us * 1e-6);
    opt.log(fmt::format("client set message {} interval to {} us", msg_id, interval_us));
  }

  // Reads what the client sent, waiting up to timeout_ms (0: only what is there); refuses other
  // clients. False when the client is gone.
  bool Poll(int timeout_ms) {
    pollfd p[2] = {{fd.get(), POLLIN, 0}, {listen_fd.get(), POLLIN, 0}};
    int r = ::poll(p, 2, timeout_ms);
    if (r < 0 && errno == EINTR) return true;
    if (r < 0) {
      End(fmt::format("poll: {}", std::strerror(errno)));
      return false;
    }
    if (p[1].revents & POLLIN) {
      Fd other(::accept(listen_fd.get(), nullptr, nullptr));
      if (other.get() >= 0) {
        ++stats.refused_clients;
        opt.log("refused a second client: one PX4 instance per server");
      }
    }
    if (p[0].revents & (POLLIN | POLLHUP | POLLERR)) {
      uint8_t buf[4096];
      const ssize_t n = ::recv(fd.get(), buf, sizeof buf, 0);
      if (n < 0 && (errno == EINTR || errno == EAGAIN)) return true;
      if (n <= 0) {
        End(n == 0 ? "client disconnected" : fmt::format("client disconnected (recv: {})", std::strerror(errno)));
        return false;
      }
      parser.Feed(buf, static_cast<size_t>(n), [this](const Frame& f) { OnFrame(f); });
    }
    return true;
  }

  void SendBattery(double t) {
    if (battery_period_s < 0 || t + 1e-9 < next_battery_t) return;
    next_battery_t = t + battery_period_s;
    const auto& pt = sim->powertrain();
    const double battery_A = sim->currents().battery_A;
    consumed_mAh += battery_A * (t - last_battery_t) / 3.6;
    last_battery_t = t;
    const double bus_V = pt.motors.empty() ? sim->setup().vehicle.battery.OpenCircuitVoltage_V(sim->soc()) : pt.bus_V;
    const BatteryStatus b = MakeBatteryStatus(bus_V, battery_A, consumed_mAh, sim->soc());
    EncodeMessage(&enc, kMsgBatteryStatus, b, &out);
    if (udp_fd.get() >= 0) {
      std::vector<uint8_t> dgram;
      EncodeMessage(&battery_enc, kMsgBatteryStatus, b, &dgram);
      // Best effort: nobody listening on the UDP port is not an error.
      (void)::sendto(udp_fd.get(), dgram.data(), dgram.size(), MSG_NOSIGNAL, reinterpret_cast<sockaddr*>(&udp_to),
                     sizeof udp_to);
    }
  }

  void SendSensors(double t) {
    const vehicle::SensorReadings& rd = sim->sensors();
    const sim::RunSetup& setup = sim->setup();
    out.clear();
    if (t + 1e-9 >= next_heartbeat_t) {
      next_heartbeat_t = t + 1.0;
      Heartbeat hb;
      hb.autopilot = 8;      // MAV_AUTOPILOT_INVALID: not an autopilot
      hb.system_status = 4;  // MAV_STATE_ACTIVE
      EncodeMessage(&enc, kMsgHeartbeat, hb, &out);
    }
    const bool mag_new = !rd.mag_uT.empty() && rd.mag_uT[0].valid && rd.mag_uT[0].t_s != last_mag_t[0];
    const bool baro_new = rd.baro.valid && rd.baro.t_s != last_baro_t;
    if (mag_new) last_mag_t[0] = rd.mag_uT[0].t_s;
    if (baro_new) last_baro_t = rd.baro.t_s;
    EncodeMessage(&enc, kMsgHilSensor, MakeHilSensor(t, rd, setup.world, mag_new, baro_new), &out);
    ++stats.sensor_messages;
    if (rd.mag_uT.size() > 1 && rd.mag_uT[1].valid && rd.mag_uT[1].t_s != last_mag_t[1]) {
      last_mag_t[1] = rd.mag_uT[1].t_s;
      EncodeMessage(&enc, kMsgHilSensor, MakeHilMag(t, rd, 1), &out);
    }
    if (rd.gps.valid && rd.gps.t_s != last_gps_t) {
      last_gps_t = rd.gps.t_s;
      EncodeMessage(&enc, kMsgHilGps, MakeHilGps(t, rd, setup.vehicle, setup.world), &out);
    }
    if (state_period_s > 0 && t + 1e-9 >= next_state_t) {
      next_state_t = t + state_period_s;
      EncodeMessage(&enc, kMsgHilStateQuaternion,
                    MakeHilState(t, sim->true_state(), sim->specific_force_B_mps2(), setup.world), &out);
    }
    SendBattery(t);
    SendAll(out);
  }

  // The command hook: one exchange per IMU sample.
  void OnImu(double t, std::vector<double>* commands) {
    if (!ended && opt.stop != nullptr && opt.stop->load()) End(kInterrupted);
    if (ended) {
      std::fill(commands->begin(), commands->end(), 0.0);
      return;
    }
    const bool lockstep = !opt.realtime && got_first_outputs;
    if (!lockstep) std::this_thread::sleep_until(wall0 + std::chrono::duration_cast<Clock::duration>(
                                                             std::chrono::duration<double>(t)));
    if (!lockstep) ++stats.paced_sensor_messages;
    awaiting_usec = TimeUsec(t);
    answered = false;
    SendSensors(t);
    if (lockstep) {
      const Clock::time_point give_up = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                           std::chrono::duration<double>(opt.idle_timeout_s));
      while (!ended && !answered) {
        const auto left_ms = std::chrono::duration_cast<std::chrono::milliseconds>(give_up - Clock::now()).count();
        if (left_ms <= 0) {
          End(fmt::format("client sent no HIL_ACTUATOR_CONTROLS for {} s", opt.idle_timeout_s));
          break;
        }
        Poll(static_cast<int>(std::min<long long>(left_ms, 100)));
        if (opt.stop != nullptr && opt.stop->load()) End(kInterrupted);
      }
    } else {
      Poll(0);
    }
    if (ended) controls.fill(0.0f);
    CommandsFromPx4Outputs(map, controls.data(), controls.size(), commands);
  }
};

Status OpenSockets(const ServeOptions& opt, Session* s) {
  auto addr = ParseAddress(opt.bind_address, opt.port, "--bind/--port");
  if (!addr.ok()) return addr.status();
  s->listen_fd.Reset(::socket(AF_INET, SOCK_STREAM, 0));
  const int one = 1;
  ::setsockopt(s->listen_fd.get(), SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  if (::bind(s->listen_fd.get(), reinterpret_cast<const sockaddr*>(&*addr), sizeof *addr) != 0 ||
      ::listen(s->listen_fd.get(), 4) != 0) {
    return Status::BadInput(fmt::format("--port: cannot listen on {}:{}: {}", opt.bind_address, opt.port,
                                        std::strerror(errno)));
  }
  sockaddr_in bound{};
  socklen_t len = sizeof bound;
  ::getsockname(s->listen_fd.get(), reinterpret_cast<sockaddr*>(&bound), &len);
  s->opt.log(fmt::format("listening on {}:{} (PX4 connects here: simulator_mavlink -c {})", opt.bind_address,
                         ntohs(bound.sin_port), ntohs(bound.sin_port)));
  if (!opt.battery_udp.empty()) {
    const size_t colon = opt.battery_udp.rfind(':');
    const int port = colon == std::string::npos ? -1 : std::atoi(opt.battery_udp.c_str() + colon + 1);
    auto to = ParseAddress(opt.battery_udp.substr(0, colon == std::string::npos ? 0 : colon), port, "--battery-udp");
    if (!to.ok()) return to.status();
    s->udp_to = *to;
    s->udp_fd.Reset(::socket(AF_INET, SOCK_DGRAM, 0));
  }
  return Status::Ok();
}

Status AcceptClient(const ServeOptions& opt, Session* s) {
  pollfd p{s->listen_fd.get(), POLLIN, 0};
  const int timeout_ms = opt.accept_timeout_s > 0 ? static_cast<int>(opt.accept_timeout_s * 1000) : -1;
  for (;;) {
    const int r = ::poll(&p, 1, opt.stop != nullptr ? std::min(timeout_ms < 0 ? 200 : timeout_ms, 200) : timeout_ms);
    if (opt.stop != nullptr && opt.stop->load()) return Status::BadInput("interrupted before a client connected");
    if (r > 0) break;
    if (r < 0 && errno != EINTR) return Status::BadInput(fmt::format("accept: {}", std::strerror(errno)));
    if (r == 0 && timeout_ms >= 0 &&
        Clock::now() - s->wall0 >= std::chrono::duration<double>(opt.accept_timeout_s)) {
      return Status::BadInput(fmt::format("--accept-timeout: no client connected within {} s", opt.accept_timeout_s));
    }
  }
  sockaddr_in peer{};
  socklen_t len = sizeof peer;
  s->fd.Reset(::accept(s->listen_fd.get(), reinterpret_cast<sockaddr*>(&peer), &len));
  if (s->fd.get() < 0) return Status::BadInput(fmt::format("accept: {}", std::strerror(errno)));
  const int one = 1;
  ::setsockopt(s->fd.get(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  char ip[INET_ADDRSTRLEN] = "?";
  inet_ntop(AF_INET, &peer.sin_addr, ip, sizeof ip);
  s->opt.log(fmt::format("client connected from {}:{}", ip, ntohs(peer.sin_port)));
  return Status::Ok();
}

}  // namespace

Result<ServeResult> ServePx4(const sim::RunSetup& setup_in, const ServeOptions& options) {
  auto map = MapPx4Rotors(setup_in.vehicle);
  if (!map.ok()) return map.status();
  Session s(options);
  s.map = *map;
  s.state_period_s = options.hil_state_rate_hz > 0 ? 1.0 / options.hil_state_rate_hz : -1.0;
  s.battery_period_s = options.battery_rate_hz > 0 ? 1.0 / options.battery_rate_hz : -1.0;
  HEXSIM_RETURN_IF_ERROR(OpenSockets(options, &s));
  HEXSIM_RETURN_IF_ERROR(AcceptClient(options, &s));
  s.wall0 = Clock::now();

  sim::RunSetup setup = setup_in;
  setup.options.end_when_landed = false;
  sim::Plugins plugins;
  plugins.command_hook = [&s](double t, const control::NavState&, std::vector<double>* c) { s.OnImu(t, c); };
  auto sim = sim::Simulation::Create(setup, std::move(plugins));
  if (!sim.ok()) return sim.status();
  s.sim = sim->get();
  while (!s.ended && (*sim)->Step()) {
  }
  if (!s.ended) s.End((*sim)->finished() ? "duration reached" : "run ended");
  ServeResult result;
  result.run = (*sim)->Finish();
  result.end_reason = s.end_reason;
  result.interrupted = s.end_reason == kInterrupted;
  s.stats.parser = s.parser.stats();
  result.stats = s.stats;
  if (result.run.summary.status != sim::RunStatus::kDiverged) {
    result.run.summary.status = sim::RunStatus::kCompleted;
    result.run.summary.reason = "PX4 flight: " + s.end_reason;
  }
  return result;
}

}  // namespace hexsim::bridge
