// The simulator side of PX4's Simulator MAVLink API: a TCP server (PX4's simulator_mavlink module
// is the client, port 4560) that flies hexsim's physics on the client's motor outputs.
//
// Each IMU sample at t (the vehicle's gyro rate) the server sends HIL_SENSOR id 0 (accel, gyro; the
// first compass and the barometer with their fields_updated bits when they have a new sample),
// HIL_SENSOR id 1 for the second compass's new samples, HIL_GPS on each new fix, HIL_STATE_QUATERNION
// (truth) at its interval (50 Hz, or what the client asks with MAV_CMD_SET_MESSAGE_INTERVAL),
// BATTERY_STATUS at 50 Hz and HEARTBEAT at 1 Hz. Then, in lockstep (the default), it waits for the
// client's HIL_ACTUATOR_CONTROLS with time_usec >= the sample's (PX4 stamps its outputs with the
// clock HIL_SENSOR set) and applies its outputs from t on: physics advances to the next IMU sample
// only after the outputs computed from this one arrived. Until the client's first
// HIL_ACTUATOR_CONTROLS (PX4 boots on the sensor stream first) and with `realtime`, sensors are
// paced at wall-clock rate and whatever outputs have arrived are applied.
//
// Bad input never stops the server: malformed frames are counted and skipped (FrameParser), unknown
// message ids ignored, a second client is accepted and closed at once, a disconnect or a silent
// client (no outputs for `idle_timeout_s` in lockstep) ends the flight, which is then logged as
// `hexsim run` logs one.
#pragma once

#include <atomic>
#include <functional>
#include <string>

#include "hexsim/bridge/mavlink.h"
#include "hexsim/common/status.h"
#include "hexsim/sim/simulation.h"

namespace hexsim::bridge {

struct ServeOptions {
  std::string bind_address = "127.0.0.1";
  int port = 4560;                 // 0: any free port (the listening line says which)
  bool realtime = false;           // true: pace at wall-clock rate, never wait for the client
  double accept_timeout_s = 0.0;   // 0: wait for a client for ever
  double idle_timeout_s = 10.0;    // lockstep: a client silent this long (wall) ends the flight
  double hil_state_rate_hz = 50.0;
  double battery_rate_hz = 50.0;
  // Also send BATTERY_STATUS (system 1, component 180 = MAV_COMP_ID_BATTERY) by UDP to this
  // "host:port", where PX4's mavlink module reads it (SITL instance 0: 127.0.0.1:14580). Empty: off.
  std::string battery_udp;
  // One line per event (listening, connected, refused, ended); the CLI prints them on stderr.
  std::function<void(const std::string&)> log = [](const std::string&) {};
  // Set from a signal handler: end the flight cleanly at the next step.
  const std::atomic<bool>* stop = nullptr;
};

struct ServeStats {
  uint64_t sensor_messages = 0;     // HIL_SENSOR id 0 sent (= lockstep steps)
  uint64_t actuator_messages = 0;   // HIL_ACTUATOR_CONTROLS received
  uint64_t stale_actuator_messages = 0;  // older than the sample being answered (applied, not counted as the answer)
  uint64_t paced_sensor_messages = 0;    // sent at wall-clock pace before lockstep engaged (or all, realtime)
  uint64_t refused_clients = 0;
  uint64_t ignored_messages = 0;    // well-formed frames of ids the server does not act on
  ParserStats parser;
};

struct ServeResult {
  sim::RunOutput run;       // log and summary, as `hexsim run` writes them
  std::string end_reason;   // why the flight ended
  bool interrupted = false; // ended by `stop` (a signal): the CLI exits 130 after writing the log
  ServeStats stats;
};

// Listens, waits for one client and flies until it disconnects, goes silent, `stop` is set or the
// run's duration (setup.options.duration_s, else max_duration_s) is reached. Errors before a client
// connected (bad address, port in use, no client within accept_timeout_s) are statuses; the setup
// must map to PX4's rotor order (MapPx4Rotors).
Result<ServeResult> ServePx4(const sim::RunSetup& setup, const ServeOptions& options);

}  // namespace hexsim::bridge
