// Cascaded multirotor controller: position P → velocity PID → thrust vector (gravity, tilt limit)
// → attitude P on the quaternion error (yaw de-prioritised) → body-rate PID → torque.
//
// Gain units (SI): pos kp [1/s] (m/s per m); vel kp [1/s²] (m/s² per m/s), ki [1/s³], kd [1/s];
// att kp [1/s] (rad/s per rad); rate kp [1/s²] (rad/s² per rad/s), ki [1/s³], kd [1/s]. The rate
// loop commands angular acceleration and the torque is τ = J·α_cmd + ω×Jω, so the gains do not
// depend on the vehicle's inertia; the velocity loop commands acceleration, so they do not depend
// on its mass either.
#pragma once

#include <limits>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "hexsim/common/status.h"
#include "hexsim/control/pid.h"
#include "hexsim/control/types.h"

namespace hexsim::control {

struct ControllerParams {
  // Position loop (P).
  double pos_xy_kp = 0.95;
  double pos_z_kp = 1.0;
  // Velocity loop (PID on each NED axis, output is acceleration m/s²).
  PidGains vel_xy{1.8, 0.4, 0.2, 5.0, 2.0, 10.0};
  PidGains vel_z{4.0, 2.0, 0.0, 10.0, 8.0, 10.0};  // I up to 0.8 g: payloads up to ~80 % of the mass
  // Attitude loop (P on the quaternion error, output is body rate).
  double att_roll_kp = 6.5;
  double att_pitch_kp = 6.5;
  double att_yaw_kp = 2.8;
  // Rate loop (PID per body axis, output is angular acceleration rad/s²).
  PidGains rate_roll{18.0, 6.0, 0.05, 60.0, 10.0, 30.0};
  PidGains rate_pitch{18.0, 6.0, 0.05, 60.0, 10.0, 30.0};
  PidGains rate_yaw{8.0, 2.0, 0.0, 15.0, 3.0, 30.0};
  // Limits.
  double max_tilt_deg = 35.0;
  double max_speed_xy_mps = 10.0;
  double max_speed_up_mps = 3.0;
  double max_speed_down_mps = 1.5;
  double max_rate_rp_dps = 220.0;
  double max_yaw_rate_dps = 90.0;
  // Collective thrust range as a fraction of the vehicle's maximum (when it is known) and of its
  // weight: the thrust never drops below min_thrust_fraction_of_weight·m·g in flight, so the
  // vehicle keeps attitude authority while descending.
  double min_thrust_fraction_of_weight = 0.1;
};

// What the controller needs to know of the vehicle.
struct VehicleModelForControl {
  double mass_kg = 1.0;
  Eigen::Matrix3d inertia_kgm2 = Eigen::Matrix3d::Identity();
  // Largest collective thrust the rotors can give; infinity when unknown.
  double max_thrust_N = std::numeric_limits<double>::infinity();
};

class Controller {
 public:
  virtual ~Controller() = default;
  virtual ControlOutput Update(const NavState& state, const Setpoint& setpoint, double dt_s) = 0;
  virtual void Reset() = 0;
};

// Intermediate commands of the last Update, for logs and tests.
struct CascadeDebug {
  Eigen::Vector3d v_sp_N_mps = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_sp_N_mps2 = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_sp_NB = Eigen::Quaterniond::Identity();
  Eigen::Vector3d w_sp_B_radps = Eigen::Vector3d::Zero();
  Eigen::Vector3d alpha_sp_B_radps2 = Eigen::Vector3d::Zero();
  bool tilt_limited = false;
};

class CascadedController final : public Controller {
 public:
  CascadedController(const ControllerParams& params, const VehicleModelForControl& vehicle);

  ControlOutput Update(const NavState& state, const Setpoint& setpoint, double dt_s) override;
  void Reset() override;

  // The inner loops alone: track an attitude and collective thrust (used by Update, and by tests and
  // manual modes). yaw_rate_ff is about the NED down axis.
  ControlOutput UpdateAttitude(const NavState& state, const Eigen::Quaterniond& q_sp_NB, double thrust_N,
                               double yaw_rate_ff_radps, double dt_s);
  // The innermost loop alone: track body rates.
  Eigen::Vector3d UpdateRates(const NavState& state, const Eigen::Vector3d& w_sp_B_radps, double dt_s);

  const CascadeDebug& debug() const { return debug_; }
  const ControllerParams& params() const { return params_; }

 private:
  ControllerParams params_;
  double tan_max_tilt_ = 0.0;  // tan(params_.max_tilt_deg), a constant (a tan per tick otherwise)
  // The ground ramp of a take-off (Setpoint::ground_ramp): collective and attitude only.
  ControlOutput UpdateOnGround(const NavState& state, const Setpoint& setpoint, double dt_s);

  VehicleModelForControl vehicle_;
  Pid vel_[3];
  Pid rate_[3];
  CascadeDebug debug_;
  bool on_ground_ = false;      // the last Update was a ground ramp
  double ground_thrust_N_ = 0.0;  // its collective
};

// Attitude that points the body's -z axis along the thrust vector F_N and has heading yaw_rad.
Eigen::Quaterniond AttitudeFromThrustAndYaw(const Eigen::Vector3d& F_N, double yaw_rad);

}  // namespace hexsim::control
