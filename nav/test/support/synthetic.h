// Test support: known trajectories and the seeded sensor streams they produce, fed to an estimator
// in arrival order.
#pragma once

#include <functional>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "hexsim/common/rng.h"
#include "hexsim/nav/estimator.h"

namespace hexsim::nav::testing {

struct Truth {
  double t_s = 0;
  Eigen::Vector3d p_N_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_N_mps = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_N_mps2 = Eigen::Vector3d::Zero();  // kinematic acceleration
  Eigen::Quaterniond q_NB = Eigen::Quaterniond::Identity();
  Eigen::Vector3d w_B_radps = Eigen::Vector3d::Zero();
};
using Trajectory = std::function<Truth(double t_s)>;

// Holds an attitude at a fixed point.
Trajectory StaticPose(double roll_rad, double pitch_rad, double yaw_rad,
                      const Eigen::Vector3d& p_N_m = Eigen::Vector3d::Zero());
// Level flight at constant velocity, nose along `yaw_rad`, from `p0_N_m` at t = 0.
Trajectory ConstantVelocity(const Eigen::Vector3d& v_N_mps, double yaw_rad,
                            const Eigen::Vector3d& p0_N_m = Eigen::Vector3d::Zero());
// Level, stationary, turning about the down axis at a constant rate.
Trajectory YawSpin(double yaw_rate_radps, double yaw0_rad);

// A multirotor flying a horizontal figure eight with a vertical weave, yaw along the velocity plus a
// swing: p = (A sin ωt, (A/2) sin 2ωt, D0 + h sin ωt). The attitude is what a multirotor needs for
// that acceleration: body z along −(a − g), nose towards the yaw. The body rate comes from the
// attitude by a central difference (exact to O(1e-8)), so gyro and accelerometer are consistent.
Trajectory FigureEight(double half_length_m, double period_s, double weave_m, double yaw_swing_rad,
                       const Eigen::Vector3d& centre_N_m = Eigen::Vector3d(0, 0, -10));

// A Changchun-like field: declination ≈ −9.4°, inclination ≈ 60°, |B| ≈ 53 µT.
Eigen::Vector3d DefaultEarthField_N_uT();

struct SensorConfig {
  int imu_rate_hz = 1000;
  int mag_rate_hz = 50;
  int gps_rate_hz = 10;
  int baro_rate_hz = 25;
  double gyro_noise_radps_rthz = 2.0e-4;
  double accel_noise_mps2_rthz = 2.0e-3;
  Eigen::Vector3d gyro_bias_B_radps = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias_B_mps2 = Eigen::Vector3d::Zero();
  double mag_noise_uT = 0.0;
  Eigen::Vector3d mag_disturbance_B_uT = Eigen::Vector3d::Zero();  // constant, body frame
  double gps_pos_std_m = 0.0;
  Eigen::Vector3d gps_bias_N_m = Eigen::Vector3d::Zero();  // constant receiver bias
  double gps_vel_std_mps = 0.0;
  double gps_delay_s = 0.0;        // arrival = validity + delay
  bool gps_stamp_on_arrival = false;  // t_s = arrival time instead of validity time
  double baro_std_m = 0.0;
  bool use_mag = true;
  bool use_gps = true;
  bool use_baro = true;
  Eigen::Vector3d B_N_uT = DefaultEarthField_N_uT();
  // Optional one-off GPS sample replacement: sample index and position offset (an outlier).
  long gps_outlier_index = -1;
  Eigen::Vector3d gps_outlier_offset_N_m = Eigen::Vector3d::Zero();
};

// Called after every IMU sample has been predicted and the measurements due at that tick fused.
using Observer = std::function<void(const Truth&, const Estimator&)>;

// Runs the IMU ticks in [t0_s, t1_s]: IMU first, then the compass and barometer taken at that
// tick, then every GPS sample whose arrival time has come (GPS samples still in flight at t1_s are
// dropped).
void RunScenario(Estimator* est, const Trajectory& traj, const SensorConfig& cfg, RngStream* rng,
                 double t0_s, double t1_s, const Observer& observer = nullptr);

// The specific force and body rate a perfect IMU reads on `truth`.
Eigen::Vector3d TrueSpecificForce_B(const Truth& truth);

// Heading (rad, from true north) an ideal tilt-compensated compass reports for the body-frame field
// m_B at true attitude q_NB: de-rotate roll and pitch, take the horizontal direction, add the
// declination. Independent of the library's X_h/Y_h formula.
double CompassHeadingRad(const Eigen::Vector3d& m_B_uT, const Eigen::Quaterniond& q_NB,
                         const Eigen::Vector3d& B_N_uT);

// NavParams matching `cfg`'s noise, with the Earth field reference set.
NavParams ParamsFor(const SensorConfig& cfg);

// An initial estimate at the truth of `traj` at t = 0, with the yaw off by `yaw_error_rad`.
NavEstimate InitialFrom(const Trajectory& traj, double yaw_error_rad);

}  // namespace hexsim::nav::testing
