// hexsim state -> Simulator MAVLink messages (sim_messages.h).
#include "hexsim/bridge/sim_messages.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "hexsim/common/rotation.h"
#include "hexsim/control/mission.h"

namespace hexsim::bridge {

namespace {
template <typename T>
T Sat(double v) {  // round and saturate to an integer field
  const double lo = static_cast<double>(std::numeric_limits<T>::min());
  const double hi = static_cast<double>(std::numeric_limits<T>::max());
  return static_cast<T>(std::clamp(std::round(std::isfinite(v) ? v : 0.0), lo, hi));
}
control::GeoPoint Home(const sim::WorldParams& w) { return {w.home_lat_deg, w.home_lon_deg, w.home_alt_m}; }
}  // namespace

uint64_t TimeUsec(double t_s) { return static_cast<uint64_t>(std::llround(t_s * 1e6)) + kTimeOffsetUsec; }
double TimeSeconds(uint64_t time_usec) { return static_cast<double>(time_usec - kTimeOffsetUsec) * 1e-6; }

double IsaPressure_hPa(double h_m) { return 1013.25 * std::pow(1.0 - 2.25577e-5 * h_m, 5.25588); }
double IsaTemperature_C(double h_m) { return 15.0 - 0.0065 * h_m; }

HilSensor MakeHilSensor(double t_s, const vehicle::SensorReadings& rd, const sim::WorldParams& world, bool mag_new,
                        bool baro_new) {
  HilSensor m;
  m.time_usec = TimeUsec(t_s);
  const Eigen::Vector3d& a = rd.accel_mps2.value;
  const Eigen::Vector3d& g = rd.gyro_radps.value;
  m.xacc = static_cast<float>(a.x());
  m.yacc = static_cast<float>(a.y());
  m.zacc = static_cast<float>(a.z());
  m.xgyro = static_cast<float>(g.x());
  m.ygyro = static_cast<float>(g.y());
  m.zgyro = static_cast<float>(g.z());
  m.fields_updated = kHilAccel | kHilGyro;
  if (mag_new && !rd.mag_uT.empty()) {
    const Eigen::Vector3d& b = rd.mag_uT[0].value;
    m.xmag = static_cast<float>(b.x() * kGaussPerUt);
    m.ymag = static_cast<float>(b.y() * kGaussPerUt);
    m.zmag = static_cast<float>(b.z() * kGaussPerUt);
    m.fields_updated |= kHilMag;
  }
  const double h_m = world.home_alt_m + rd.baro.alt_m;
  m.abs_pressure = static_cast<float>(IsaPressure_hPa(h_m));
  m.pressure_alt = static_cast<float>(h_m);
  m.temperature = static_cast<float>(IsaTemperature_C(h_m));
  if (baro_new) m.fields_updated |= kHilBaro;
  m.id = 0;
  return m;
}

HilSensor MakeHilMag(double t_s, const vehicle::SensorReadings& rd, uint8_t id) {
  HilSensor m;
  m.time_usec = TimeUsec(t_s);
  const Eigen::Vector3d& b = rd.mag_uT.at(id).value;
  m.xmag = static_cast<float>(b.x() * kGaussPerUt);
  m.ymag = static_cast<float>(b.y() * kGaussPerUt);
  m.zmag = static_cast<float>(b.z() * kGaussPerUt);
  m.fields_updated = kHilMag;
  m.id = id;
  return m;
}

HilGps MakeHilGps(double t_s, const vehicle::SensorReadings& rd, const vehicle::VehicleParams& v,
                  const sim::WorldParams& world) {
  HilGps m;
  m.time_usec = TimeUsec(t_s);
  const control::GeoPoint p = control::NedToLatLon(Home(world), rd.gps.p_N_m);
  m.lat = Sat<int32_t>(p.lat_deg * 1e7);
  m.lon = Sat<int32_t>(p.lon_deg * 1e7);
  m.alt = Sat<int32_t>((world.home_alt_m - rd.gps.p_N_m.z()) * 1e3);
  m.eph = Sat<uint16_t>(std::max(1.0, v.sensors.gps.horizontal_m.noise_std * 100.0));
  m.epv = Sat<uint16_t>(std::max(1.0, v.sensors.gps.vertical_m.noise_std * 100.0));
  const Eigen::Vector3d& vel = rd.gps.v_N_mps;
  m.vel = Sat<uint16_t>(std::hypot(vel.x(), vel.y()) * 100.0);
  m.vn = Sat<int16_t>(vel.x() * 100.0);
  m.ve = Sat<int16_t>(vel.y() * 100.0);
  m.vd = Sat<int16_t>(vel.z() * 100.0);
  double cog_deg = std::atan2(vel.y(), vel.x()) * kRadToDeg;
  if (cog_deg < 0) cog_deg += 360.0;
  m.cog = Sat<uint16_t>(std::fmod(cog_deg * 100.0, 36000.0));
  m.fix_type = 3;  // 3D
  m.satellites_visible = 10;
  m.id = 0;
  return m;
}

HilStateQuaternion MakeHilState(double t_s, const sim::BodyState& s, const Eigen::Vector3d& specific_force_B_mps2,
                                const sim::WorldParams& world) {
  HilStateQuaternion m;
  m.time_usec = TimeUsec(t_s);
  const Eigen::Quaterniond& q = s.q_NB;
  m.attitude_quaternion = {static_cast<float>(q.w()), static_cast<float>(q.x()), static_cast<float>(q.y()),
                           static_cast<float>(q.z())};
  m.rollspeed = static_cast<float>(s.w_B_radps.x());
  m.pitchspeed = static_cast<float>(s.w_B_radps.y());
  m.yawspeed = static_cast<float>(s.w_B_radps.z());
  const control::GeoPoint p = control::NedToLatLon(Home(world), s.p_N_m);
  m.lat = Sat<int32_t>(p.lat_deg * 1e7);
  m.lon = Sat<int32_t>(p.lon_deg * 1e7);
  m.alt = Sat<int32_t>((world.home_alt_m - s.p_N_m.z()) * 1e3);
  m.vx = Sat<int16_t>(s.v_N_mps.x() * 100.0);
  m.vy = Sat<int16_t>(s.v_N_mps.y() * 100.0);
  m.vz = Sat<int16_t>(s.v_N_mps.z() * 100.0);
  const double mg_per_mps2 = 1000.0 / kGravity_mps2;
  m.xacc = Sat<int16_t>(specific_force_B_mps2.x() * mg_per_mps2);
  m.yacc = Sat<int16_t>(specific_force_B_mps2.y() * mg_per_mps2);
  m.zacc = Sat<int16_t>(specific_force_B_mps2.z() * mg_per_mps2);
  return m;
}

BatteryStatus MakeBatteryStatus(double bus_V, double battery_A, double consumed_mAh, double soc) {
  BatteryStatus m;
  m.voltages.fill(UINT16_MAX);
  m.voltages[0] = Sat<uint16_t>(std::min(bus_V * 1000.0, 65534.0));
  m.voltages_ext.fill(0);
  m.current_battery = Sat<int16_t>(battery_A * 100.0);
  m.current_consumed = Sat<int32_t>(consumed_mAh);
  m.battery_remaining = Sat<int8_t>(std::clamp(soc, 0.0, 1.0) * 100.0);
  m.id = 0;
  m.battery_function = 1;  // MAV_BATTERY_FUNCTION_ALL
  m.type = 1;              // MAV_BATTERY_TYPE_LIPO
  return m;
}

}  // namespace hexsim::bridge
