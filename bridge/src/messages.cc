// Wire layouts of the bridge's MAVLink messages (messages.h): little-endian, fields in wire order.
#include "hexsim/bridge/messages.h"

#include <cstring>
#include <type_traits>

namespace hexsim::bridge {

namespace {

class Writer {
 public:
  explicit Writer(uint32_t id) : out_(FindMessage(id)->max_len, 0) {}
  template <typename T>
  Writer& Put(T v) {
    static_assert(std::is_arithmetic_v<T>);
    std::memcpy(out_.data() + at_, &v, sizeof v);  // hexsim targets little-endian hosts (x86-64, arm64)
    at_ += sizeof v;
    return *this;
  }
  template <typename T, size_t N>
  Writer& Put(const std::array<T, N>& a) {
    for (const T& v : a) Put(v);
    return *this;
  }
  std::vector<uint8_t> Done() { return std::move(out_); }

 private:
  std::vector<uint8_t> out_;
  size_t at_ = 0;
};

class Reader {
 public:
  explicit Reader(const Frame& f) : p_(f.payload.data()) {}
  template <typename T>
  Reader& Get(T* v) {
    std::memcpy(v, p_ + at_, sizeof *v);
    at_ += sizeof *v;
    return *this;
  }
  template <typename T, size_t N>
  Reader& Get(std::array<T, N>* a) {
    for (T& v : *a) Get(&v);
    return *this;
  }

 private:
  const uint8_t* p_;
  size_t at_ = 0;
};

}  // namespace

std::vector<uint8_t> Pack(const Heartbeat& m) {
  return Writer(kMsgHeartbeat).Put(m.custom_mode).Put(m.type).Put(m.autopilot).Put(m.base_mode)
      .Put(m.system_status).Put(m.mavlink_version).Done();
}
Heartbeat UnpackHeartbeat(const Frame& f) {
  Heartbeat m;
  Reader(f).Get(&m.custom_mode).Get(&m.type).Get(&m.autopilot).Get(&m.base_mode).Get(&m.system_status)
      .Get(&m.mavlink_version);
  return m;
}

std::vector<uint8_t> Pack(const CommandLong& m) {
  return Writer(kMsgCommandLong).Put(m.param).Put(m.command).Put(m.target_system).Put(m.target_component)
      .Put(m.confirmation).Done();
}
CommandLong UnpackCommandLong(const Frame& f) {
  CommandLong m;
  Reader(f).Get(&m.param).Get(&m.command).Get(&m.target_system).Get(&m.target_component).Get(&m.confirmation);
  return m;
}

std::vector<uint8_t> Pack(const HilActuatorControls& m) {
  return Writer(kMsgHilActuatorControls).Put(m.time_usec).Put(m.flags).Put(m.controls).Put(m.mode).Done();
}
HilActuatorControls UnpackHilActuatorControls(const Frame& f) {
  HilActuatorControls m;
  Reader(f).Get(&m.time_usec).Get(&m.flags).Get(&m.controls).Get(&m.mode);
  return m;
}

std::vector<uint8_t> Pack(const HilSensor& m) {
  return Writer(kMsgHilSensor).Put(m.time_usec).Put(m.xacc).Put(m.yacc).Put(m.zacc).Put(m.xgyro).Put(m.ygyro)
      .Put(m.zgyro).Put(m.xmag).Put(m.ymag).Put(m.zmag).Put(m.abs_pressure).Put(m.diff_pressure)
      .Put(m.pressure_alt).Put(m.temperature).Put(m.fields_updated).Put(m.id).Done();
}
HilSensor UnpackHilSensor(const Frame& f) {
  HilSensor m;
  Reader(f).Get(&m.time_usec).Get(&m.xacc).Get(&m.yacc).Get(&m.zacc).Get(&m.xgyro).Get(&m.ygyro).Get(&m.zgyro)
      .Get(&m.xmag).Get(&m.ymag).Get(&m.zmag).Get(&m.abs_pressure).Get(&m.diff_pressure).Get(&m.pressure_alt)
      .Get(&m.temperature).Get(&m.fields_updated).Get(&m.id);
  return m;
}

std::vector<uint8_t> Pack(const HilGps& m) {
  return Writer(kMsgHilGps).Put(m.time_usec).Put(m.lat).Put(m.lon).Put(m.alt).Put(m.eph).Put(m.epv).Put(m.vel)
      .Put(m.vn).Put(m.ve).Put(m.vd).Put(m.cog).Put(m.fix_type).Put(m.satellites_visible).Put(m.id).Put(m.yaw)
      .Done();
}
HilGps UnpackHilGps(const Frame& f) {
  HilGps m;
  Reader(f).Get(&m.time_usec).Get(&m.lat).Get(&m.lon).Get(&m.alt).Get(&m.eph).Get(&m.epv).Get(&m.vel).Get(&m.vn)
      .Get(&m.ve).Get(&m.vd).Get(&m.cog).Get(&m.fix_type).Get(&m.satellites_visible).Get(&m.id).Get(&m.yaw);
  return m;
}

std::vector<uint8_t> Pack(const HilStateQuaternion& m) {
  return Writer(kMsgHilStateQuaternion).Put(m.time_usec).Put(m.attitude_quaternion).Put(m.rollspeed)
      .Put(m.pitchspeed).Put(m.yawspeed).Put(m.lat).Put(m.lon).Put(m.alt).Put(m.vx).Put(m.vy).Put(m.vz)
      .Put(m.ind_airspeed).Put(m.true_airspeed).Put(m.xacc).Put(m.yacc).Put(m.zacc).Done();
}
HilStateQuaternion UnpackHilStateQuaternion(const Frame& f) {
  HilStateQuaternion m;
  Reader(f).Get(&m.time_usec).Get(&m.attitude_quaternion).Get(&m.rollspeed).Get(&m.pitchspeed).Get(&m.yawspeed)
      .Get(&m.lat).Get(&m.lon).Get(&m.alt).Get(&m.vx).Get(&m.vy).Get(&m.vz).Get(&m.ind_airspeed)
      .Get(&m.true_airspeed).Get(&m.xacc).Get(&m.yacc).Get(&m.zacc);
  return m;
}

std::vector<uint8_t> Pack(const BatteryStatus& m) {
  return Writer(kMsgBatteryStatus).Put(m.current_consumed).Put(m.energy_consumed).Put(m.temperature)
      .Put(m.voltages).Put(m.current_battery).Put(m.id).Put(m.battery_function).Put(m.type)
      .Put(m.battery_remaining).Put(m.time_remaining).Put(m.charge_state).Put(m.voltages_ext).Put(m.mode)
      .Put(m.fault_bitmask).Done();
}
BatteryStatus UnpackBatteryStatus(const Frame& f) {
  BatteryStatus m;
  Reader(f).Get(&m.current_consumed).Get(&m.energy_consumed).Get(&m.temperature).Get(&m.voltages)
      .Get(&m.current_battery).Get(&m.id).Get(&m.battery_function).Get(&m.type).Get(&m.battery_remaining)
      .Get(&m.time_remaining).Get(&m.charge_state).Get(&m.voltages_ext).Get(&m.mode).Get(&m.fault_bitmask);
  return m;
}

}  // namespace hexsim::bridge
