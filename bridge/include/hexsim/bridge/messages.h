// The MAVLink messages of PX4's Simulator MAVLink API, as plain structs with their wire layout
// (common.xml / minimal.xml, the version cited in mavlink.cc; fields in wire order: by type size,
// extensions last). Pack* writes the full-length little-endian payload; Unpack* reads a Frame
// (whose payload the parser zero-filled, so truncated trailing fields read as zero).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "hexsim/bridge/mavlink.h"

namespace hexsim::bridge {

enum MsgId : uint32_t {
  kMsgHeartbeat = 0,
  kMsgCommandLong = 76,
  kMsgHilActuatorControls = 93,
  kMsgHilSensor = 107,
  kMsgHilGps = 113,
  kMsgHilStateQuaternion = 115,
  kMsgBatteryStatus = 147,
};

inline constexpr uint16_t kMavCmdSetMessageInterval = 511;

struct Heartbeat {  // id 0
  uint32_t custom_mode = 0;
  uint8_t type = 0;        // MAV_TYPE
  uint8_t autopilot = 0;   // MAV_AUTOPILOT (8: invalid, i.e. not an autopilot)
  uint8_t base_mode = 0;
  uint8_t system_status = 0;
  uint8_t mavlink_version = 3;
};

struct CommandLong {  // id 76
  std::array<float, 7> param{};
  uint16_t command = 0;
  uint8_t target_system = 0, target_component = 0, confirmation = 0;
};

struct HilActuatorControls {  // id 93
  uint64_t time_usec = 0;
  uint64_t flags = 0;       // bit 0: the sender runs lockstep
  std::array<float, 16> controls{};
  uint8_t mode = 0;         // MAV_MODE flags; 128 = armed
};

// fields_updated bits of HIL_SENSOR (common.xml HIL_SENSOR_UPDATED_FLAGS).
enum HilSensorBits : uint32_t {
  kHilAccel = 0x7,
  kHilGyro = 0x38,
  kHilMag = 0x1C0,
  kHilAbsPressure = 0x200,
  kHilDiffPressure = 0x400,
  kHilPressureAlt = 0x800,
  kHilTemperature = 0x1000,
  kHilBaro = kHilAbsPressure | kHilPressureAlt | kHilTemperature,  // PX4's SensorSource::BARO
  kHilReset = 0x80000000u,
};

struct HilSensor {  // id 107
  uint64_t time_usec = 0;
  float xacc = 0, yacc = 0, zacc = 0;     // m/s^2, body FRD
  float xgyro = 0, ygyro = 0, zgyro = 0;  // rad/s
  float xmag = 0, ymag = 0, zmag = 0;     // gauss
  float abs_pressure = 0;                 // hPa
  float diff_pressure = 0;                // hPa
  float pressure_alt = 0;                 // m
  float temperature = 0;                  // degC
  uint32_t fields_updated = 0;
  uint8_t id = 0;                         // extension
};

struct HilGps {  // id 113
  uint64_t time_usec = 0;
  int32_t lat = 0, lon = 0;   // degE7
  int32_t alt = 0;            // mm above MSL
  uint16_t eph = 0, epv = 0;  // cm (dimensionless DOP in the spec; PX4 reads them as cm)
  uint16_t vel = 0;           // cm/s ground speed
  int16_t vn = 0, ve = 0, vd = 0;  // cm/s
  uint16_t cog = 0;           // cdeg, 65535 unknown
  uint8_t fix_type = 0;
  uint8_t satellites_visible = 0;
  uint8_t id = 0;             // extension
  uint16_t yaw = 0;           // extension: cdeg, 0 = not available
};

struct HilStateQuaternion {  // id 115
  uint64_t time_usec = 0;
  std::array<float, 4> attitude_quaternion{1, 0, 0, 0};  // w x y z, body FRD to NED
  float rollspeed = 0, pitchspeed = 0, yawspeed = 0;     // rad/s
  int32_t lat = 0, lon = 0, alt = 0;                     // degE7, degE7, mm
  int16_t vx = 0, vy = 0, vz = 0;                        // cm/s NED
  uint16_t ind_airspeed = 0, true_airspeed = 0;          // cm/s
  int16_t xacc = 0, yacc = 0, zacc = 0;                  // mG
};

struct BatteryStatus {  // id 147
  int32_t current_consumed = -1;  // mAh
  int32_t energy_consumed = -1;   // hJ
  int16_t temperature = INT16_MAX;  // cdegC, INT16_MAX unknown
  std::array<uint16_t, 10> voltages{};  // mV; cell 0 the pack when cells are not measured
  int16_t current_battery = -1;   // cA
  uint8_t id = 0, battery_function = 0, type = 0;
  int8_t battery_remaining = -1;  // %
  int32_t time_remaining = 0;     // extensions from here
  uint8_t charge_state = 0;
  std::array<uint16_t, 4> voltages_ext{};
  uint8_t mode = 0;
  uint32_t fault_bitmask = 0;
};

// Full-length payloads (FindMessage(id)->max_len bytes).
std::vector<uint8_t> Pack(const Heartbeat& m);
std::vector<uint8_t> Pack(const CommandLong& m);
std::vector<uint8_t> Pack(const HilActuatorControls& m);
std::vector<uint8_t> Pack(const HilSensor& m);
std::vector<uint8_t> Pack(const HilGps& m);
std::vector<uint8_t> Pack(const HilStateQuaternion& m);
std::vector<uint8_t> Pack(const BatteryStatus& m);

// The frame's payload read as the message (the caller checked frame.msgid).
Heartbeat UnpackHeartbeat(const Frame& f);
CommandLong UnpackCommandLong(const Frame& f);
HilActuatorControls UnpackHilActuatorControls(const Frame& f);
HilSensor UnpackHilSensor(const Frame& f);
HilGps UnpackHilGps(const Frame& f);
HilStateQuaternion UnpackHilStateQuaternion(const Frame& f);
BatteryStatus UnpackBatteryStatus(const Frame& f);

// Encode(message) through an encoder, appended to *out.
template <typename Msg>
void EncodeMessage(FrameEncoder* enc, uint32_t id, const Msg& m, std::vector<uint8_t>* out) {
  const std::vector<uint8_t> p = Pack(m);
  enc->Encode(id, p.data(), p.size(), out);
}

}  // namespace hexsim::bridge
