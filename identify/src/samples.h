// The per-sample data the identification fits (private): one entry per IMU sample in flight, every
// other stream held at its latest sample at or before it (never interpolated).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexsim/identify/identify.h"

namespace hexsim::identify::internal {

using Vec3 = Eigen::Vector3d;

// Motor lag grid (s), the physical range 5–300 ms; 0 = no lag beyond the log's own hold.
inline constexpr double kTauGrid_s[] = {0.0, 0.005, 0.01, 0.015, 0.02, 0.03, 0.04, 0.05, 0.065, 0.08, 0.1, 0.13, 0.17, 0.22, 0.3};
inline constexpr size_t kTauCount = sizeof(kTauGrid_s) / sizeof(kTauGrid_s[0]);

// Thrust-curve sums of the motor outputs x_i = u_i·V/V_ref at one instant, each first-order lagged by
// the grid's τ: S1 = Σ x_i, S2 = Σ x_i², Z1 = Σ s_i·x_i, Z2 = Σ s_i·x_i² (s_i the rotor spin).
struct LaggedSums {
  double S1[kTauCount] = {}, S2[kTauCount] = {}, Z1[kTauCount] = {}, Z2[kTauCount] = {};
};

struct FlightSamples {
  std::vector<double> t_s;
  std::vector<Vec3> f_B;             // specific force, body (accelerometer)
  std::vector<Vec3> w_B;             // body rate (gyro)
  std::vector<double> r_dot;         // yaw acceleration (central difference of the gyro's z)
  std::vector<Vec3> v_B;             // body velocity (EKF/truth velocity rotated by the attitude)
  std::vector<double> u_mean, V;     // mean motor output, bus voltage (held)
  std::vector<std::vector<double>> u;  // every motor's output (held)
  std::vector<LaggedSums> sums;
  std::vector<int> block;            // 0..blocks-1
  double V_ref = 0.0;                // median bus voltage in flight
  double imu_rate_hz = 0.0, rcou_rate_hz = 0.0;
  size_t motors = 0;
  double z0 = 0.0;                   // Σ s_i (0 for a balanced frame)
  // Battery samples in flight windows (own rate): V, I and the charge drawn since the log start.
  // batt_Q_Ah is the left Riemann sum of the sampled current, batt_Q_right_Ah the right one: the
  // charge actually drawn between two samples is known only to about their difference.
  std::vector<double> batt_t_s, batt_V, batt_I, batt_Q_Ah, batt_Q_right_Ah;
  std::vector<int> batt_block;
  // Second differences of consecutive IMU samples in flight (noise): Δ²gyro, Δ²accel.
  std::vector<Vec3> d_gyro, d_accel;
  std::vector<int> d_block;
  std::vector<FlightWindow> windows;
  std::vector<BlockSpan> blocks;
  std::string source;
  std::vector<std::string> notes;    // what was left out and why (e.g. no power monitor)
  // The logged velocity follows the accelerometer (realdata::CheckVelocityAgainstAccel); when it does
  // not, v_B is zero throughout and the drag parameters are not identified (velocity_why says why).
  bool velocity_ok = true;
  std::string velocity_why;
};

// Builds the samples. `spins` per motor (size = motors). Bad input when the log lacks accel, gyro,
// motor outputs or attitude, or has less than options.min_flight_s of flight. weight_N: the base
// vehicle's weight (the flight power check of the logged current).
Result<FlightSamples> BuildSamples(const logs::FlightLog& log, const std::vector<int>& spins,
                                   const IdentifyOptions& options, double weight_N);

// Frame table (ArduPilot AP_MotorsMatrix): rotor angle (deg, clockwise from the nose) and spin per
// motor number. Empty for an unknown frame.
struct FrameRotor {
  double angle_deg = 0.0;
  int spin = 1;  // +1 CCW seen from above
};
std::vector<FrameRotor> FrameRotors(const std::string& frame);
// The frame name of ArduPilot's FRAME_CLASS (1 quad, 2 hexa, 3 octa) and FRAME_TYPE, "" when the table
// has no entry for it.
std::string FrameNameFor(int frame_class, int frame_type);
// Fills result->spins, rotor_xy_m, layout_source and layout_from_log for result->motors motors (frame.cc).
// Bad input when the base vehicle has fewer rotors than the frame where its layout is needed.
Status ChooseLayout(const logs::FlightLog& log, const vehicle::VehicleParams& base, const std::vector<FrameRotor>& table,
                    IdentifyResult* result);

}  // namespace hexsim::identify::internal
