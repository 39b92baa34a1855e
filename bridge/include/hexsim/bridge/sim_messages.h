// hexsim's sensors and truth as PX4's Simulator MAVLink messages (pure functions, no I/O).
//
// Units: accel m/s^2 and gyro rad/s in body FRD as the IMU reads them; magnetometer in gauss
// (1 G = 100 uT) exactly as hexsim's compass model reads (the same samples `hexsim run` logs);
// pressure from the barometer's altitude through the ISA troposphere
//   p = 1013.25 hPa * (1 - 2.25577e-5 * h)^5.25588,  T = 15 - 0.0065 * h degC,  h = home_alt_m + baro_alt_m;
// GPS NED -> lat/lon by control::NedToLatLon about the world's home point.
// time_usec = 1e6 * t_s + kTimeOffsetUsec: PX4 treats a zero time stamp as "never".
#pragma once

#include <cstdint>

#include "hexsim/bridge/messages.h"
#include "hexsim/sim/rigid_body.h"
#include "hexsim/sim/world.h"
#include "hexsim/vehicle/sensors.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::bridge {

inline constexpr uint64_t kTimeOffsetUsec = 1000000;
inline constexpr double kGaussPerUt = 0.01;

uint64_t TimeUsec(double t_s);
double TimeSeconds(uint64_t time_usec);

// ISA troposphere (valid to 11 km): pressure in hPa and temperature in degC at height h_m (MSL).
double IsaPressure_hPa(double h_m);
double IsaTemperature_C(double h_m);

// HIL_SENSOR id 0: IMU sample at t_s; the first compass and the barometer are included, with their
// fields_updated bits, only when `mag_new` / `baro_new`.
HilSensor MakeHilSensor(double t_s, const vehicle::SensorReadings& rd, const sim::WorldParams& world, bool mag_new,
                        bool baro_new);
// HIL_SENSOR id `id` carrying only compass `id` (PX4 takes two: ids 0 and 1).
HilSensor MakeHilMag(double t_s, const vehicle::SensorReadings& rd, uint8_t id);
// HIL_GPS of the receiver's latest fix (eph/epv from the vehicle's GPS noise, in cm).
HilGps MakeHilGps(double t_s, const vehicle::SensorReadings& rd, const vehicle::VehicleParams& v,
                  const sim::WorldParams& world);
// Ground truth: attitude, body rates, position, velocity, specific force in mG.
HilStateQuaternion MakeHilState(double t_s, const sim::BodyState& s, const Eigen::Vector3d& specific_force_B_mps2,
                                const sim::WorldParams& world);
// The pack's voltage (cell 0 holds the whole pack, as common.xml asks when cells are not measured)
// and current, consumed charge and remaining charge.
BatteryStatus MakeBatteryStatus(double bus_V, double battery_A, double consumed_mAh, double soc);

}  // namespace hexsim::bridge
