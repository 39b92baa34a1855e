// The onboard navigation interface: sensor samples in, a navigation estimate out.
//
// Every estimator (the error-state Kalman filter "eskf", the Mahony-style "complementary", or a
// user's own) implements `Estimator`. Samples are fed in arrival order; a sample's `t_s` is its time
// of validity. Non-finite samples are rejected and counted, never propagated; a non-finite or
// diverging internal state turns Health() into a kNumerical status naming the quantity and time,
// and the estimator then holds its last good state.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "hexsim/common/status.h"

namespace hexsim::nav {

struct ImuSample {
  double t_s = 0;
  Eigen::Vector3d gyro_B_radps = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_B_mps2 = Eigen::Vector3d::Zero();  // specific force (at rest: -g along down)
};
// Already compensated for hard/soft iron and current-driven disturbance.
struct MagSample {
  double t_s = 0;
  Eigen::Vector3d mag_B_uT = Eigen::Vector3d::Zero();
};
struct GpsSample {
  double t_s = 0;  // time of validity (see NavParams::gps_delay_s for receivers that stamp on arrival)
  Eigen::Vector3d p_N_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_N_mps = Eigen::Vector3d::Zero();
};
struct BaroSample {
  double t_s = 0;
  double alt_m = 0;  // height above the home position (= -p_D at home level)
};

struct NavEstimate {
  double t_s = 0;
  Eigen::Vector3d p_N_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_N_mps = Eigen::Vector3d::Zero();
  Eigen::Vector3d w_B_radps = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_bias_B_radps = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias_B_mps2 = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_NB = Eigen::Quaterniond::Identity();
  double yaw_std_rad = 0;
  // false: not yet aligned (or diverged). Passed to Reset(): false requests static alignment.
  bool healthy = true;
};

// Earth field at the home position (WMM; the app computes it). Declination = atan2(B_E, B_N).
struct EarthFieldReference {
  Eigen::Vector3d B_N_uT = Eigen::Vector3d::Zero();
};

// Per-sensor measurement bookkeeping.
struct SensorStats {
  int64_t fused = 0;
  int64_t rejected_gate = 0;       // innovation outside the gate
  int64_t rejected_invalid = 0;    // non-finite sample, or older than the state buffer
  Eigen::Vector3d last_innovation = Eigen::Vector3d::Zero();  // heading mode: (Δψ_rad, 0, 0)
  double last_test_ratio = 0;      // largest |innovation| / gate over the components (≤ 1 passes)
  // State resets to this sensor after it was gated out too long (GPS: position/velocity reset;
  // compass: yaw reset), as EKF2 does, so a lost estimate recovers instead of locking the sensor out.
  int64_t resets = 0;
};
struct EstimatorStats {
  int64_t imu_samples = 0;
  int64_t imu_rejected_invalid = 0;
  SensorStats mag, gps_pos, gps_vel, baro;
};

enum class MagMode { kHeading, kThreeAxis };

// Defaults: a typical MEMS IMU sampled at 1 kHz, a consumer GNSS receiver, a MEMS barometer.
struct NavParams {
  std::string estimator = "eskf";  // "eskf" | "complementary"
  // IMU noise (continuous-time densities) and bias random walks.
  double gyro_noise_radps_rthz = 2.0e-4;      // ≈ 0.011 °/s/√Hz
  double accel_noise_mps2_rthz = 2.0e-3;      // ≈ 200 µg/√Hz
  double gyro_bias_rw_radps2_rthz = 5.0e-5;   // rad/s per √s
  double accel_bias_rw_mps3_rthz = 1.0e-3;    // m/s² per √s (EKF2's ACC_B_NOISE is 3e-3)
  // Measurement noise.
  MagMode mag_mode = MagMode::kHeading;
  double mag_heading_std_rad = 0.03;          // heading mode
  double mag_std_uT = 0.5;                    // 3-axis mode, per axis
  double gps_pos_std_m = 0.5;
  double gps_vel_std_mps = 0.1;
  double baro_std_m = 0.5;
  // Innovation gates in standard deviations of the innovation.
  double mag_gate_sigma = 5.0;
  double gps_gate_sigma = 5.0;
  double baro_gate_sigma = 5.0;
  // ESKF recovery (EKF2-style): while GPS samples keep arriving but none passed the horizontal
  // position gate for this long, position and velocity are reset to GPS; while compass samples keep
  // arriving but none passed the heading gate for this long, the yaw is reset to the compass.
  double gps_reset_timeout_s = 5.0;
  double mag_yaw_reset_timeout_s = 5.0;
  // Added to a GPS sample's t_s for receivers that stamp on arrival: t_valid = t_s - gps_delay_s.
  double gps_delay_s = 0.0;
  // Initial standard deviations (used by Reset and at the end of static alignment).
  double init_tilt_std_rad = 0.05;
  double init_yaw_std_rad = 0.3;
  double init_vel_std_mps = 0.5;
  double init_pos_std_m = 3.0;
  double init_gyro_bias_std_radps = 0.02;
  double init_accel_bias_std_mps2 = 0.3;
  // Static alignment: averaging time after Reset(healthy=false).
  double align_time_s = 1.0;
  // ESKF: the covariance is propagated at the filter rate on the accumulated IMU interval (summed
  // dt and delta velocity), as PX4's EKF2 predicts at EKF2_PREDICT_US = 10 ms (100 Hz) and
  // ArduPilot's EKF3 at EKF_TARGET_DT_MS = 12 ms on down-sampled delta angles and velocities; the
  // nominal state (what the controller reads) still integrates every IMU sample, as their output
  // predictors do. Physical range 50–1000 Hz (at or below the IMU rate; 0 = every sample); a
  // propagation also waits for at least cov_predict_every_n samples (1 = no such floor).
  double cov_predict_rate_hz = 100.0;
  int cov_predict_every_n = 1;
  // Complementary filter gains.
  double comp_tilt_gain_radps = 1.0;      // Kp on the gravity-direction error (1/s)
  double comp_yaw_gain_radps = 0.5;       // Kp on the heading error (1/s)
  double comp_bias_gain_rad = 0.05;       // Ki (1/s²)
  double comp_pos_gain = 0.1;             // fraction of the GPS position error taken per update
  double comp_vel_from_pos_gain = 0.1;    // velocity correction per update per metre of error (1/s)
  double comp_vel_gain = 0.2;             // fraction of the GPS velocity error taken per update
  double comp_baro_gain = 0.05;           // fraction of the baro altitude error taken per update
  double comp_pos_std_m = 1.0;            // nominal state std for its gates
  double comp_vel_std_mps = 0.5;
  int comp_reset_after_rejections = 20;   // consecutive gated GPS samples before a position reset
  EarthFieldReference earth;
};

class Estimator {
 public:
  virtual ~Estimator() = default;
  virtual std::string name() const = 0;
  // Starts from `initial`; when initial.healthy is false, aligns statically: roll/pitch from the
  // mean accelerometer, yaw from the mean compass, gyro bias from the mean gyro over
  // NavParams::align_time_s, position/velocity from initial.
  virtual void Reset(const NavEstimate& initial) = 0;
  virtual void PredictImu(const ImuSample&) = 0;
  virtual void FuseMag(const MagSample&) = 0;
  virtual void FuseGps(const GpsSample&) = 0;
  virtual void FuseBaro(const BaroSample&) = 0;
  virtual NavEstimate Estimate() const = 0;
  virtual Status Health() const = 0;
  virtual EstimatorStats Stats() const = 0;
};

// "eskf" | "complementary"; an unknown name or invalid params is kBadInput.
Result<std::unique_ptr<Estimator>> MakeEstimator(const std::string& name, const NavParams& params);

// Checks ranges and the Earth field (non-zero horizontal component); message names the field.
Status ValidateNavParams(const NavParams& params);

// Tilt-compensated magnetic heading (NED/FRD): X_h = m_x cosθ + m_y sinφ sinθ + m_z cosφ sinθ,
// Y_h = m_y cosφ − m_z sinφ, ψ_mag = atan2(−Y_h, X_h).
double TiltCompensatedHeadingRad(const Eigen::Vector3d& mag_B_uT, double roll_rad, double pitch_rad);
// Declination of the reference field, atan2(B_E, B_N).
double DeclinationRad(const EarthFieldReference& earth);

}  // namespace hexsim::nav
