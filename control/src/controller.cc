#include "hexsim/control/controller.h"

#include <algorithm>
#include <cmath>

#include "hexsim/common/rotation.h"

namespace hexsim::control {

using Eigen::Matrix3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;

Quaterniond AttitudeFromThrustAndYaw(const Vector3d& F_N, double yaw_rad) {
  const double norm = F_N.norm();
  const Vector3d z_B = norm > 1e-9 ? Vector3d(-F_N / norm) : Vector3d::UnitZ();
  // x_B ⊥ y_C keeps x_B in the vertical plane of heading ψ, so the ZYX Euler yaw is exactly ψ.
  const Vector3d y_C(-std::sin(yaw_rad), std::cos(yaw_rad), 0.0);
  Vector3d x_B = y_C.cross(z_B);
  if (x_B.norm() < 1e-6) x_B = Vector3d(std::cos(yaw_rad), std::sin(yaw_rad), 0.0);  // z_B ∥ y_C
  x_B.normalize();
  const Vector3d y_B = z_B.cross(x_B);
  Matrix3d R_NB;
  R_NB.col(0) = x_B;
  R_NB.col(1) = y_B;
  R_NB.col(2) = z_B;
  return Quaterniond(R_NB).normalized();
}

CascadedController::CascadedController(const ControllerParams& params, const VehicleModelForControl& vehicle)
    : params_(params), tan_max_tilt_(std::tan(params.max_tilt_deg * kDegToRad)), vehicle_(vehicle) {
  HEXSIM_CHECK(vehicle.mass_kg > 0.0);
  vel_[0].set_gains(params.vel_xy);
  vel_[1].set_gains(params.vel_xy);
  vel_[2].set_gains(params.vel_z);
  rate_[0].set_gains(params.rate_roll);
  rate_[1].set_gains(params.rate_pitch);
  rate_[2].set_gains(params.rate_yaw);
}

void CascadedController::Reset() {
  for (Pid& p : vel_) p.Reset();
  for (Pid& p : rate_) p.Reset();
  debug_ = CascadeDebug();
  on_ground_ = false;
  ground_thrust_N_ = 0.0;
}

// Ground ramp (ArduPilot auto_takeoff_run while land_complete): level at the setpoint's yaw, the
// collective as ramped, the velocity loops reset and the rate integrators held at zero (they would
// wind up against the ground's reaction).
ControlOutput CascadedController::UpdateOnGround(const NavState& state, const Setpoint& setpoint, double dt_s) {
  const double m = vehicle_.mass_kg;
  for (Pid& p : vel_) p.Reset();
  for (Pid& p : rate_) p.set_integrator(0.0);
  // Full scale: the vehicle's largest thrust, or twice its weight when that is unknown.
  const double full_N = std::isfinite(vehicle_.max_thrust_N) ? vehicle_.max_thrust_N : 2.0 * m * kGravity_mps2;
  ground_thrust_N_ = std::clamp(setpoint.ground_thrust_fraction, 0.0, 1.0) * full_N;
  on_ground_ = true;
  const Quaterniond q_sp = AttitudeFromThrustAndYaw(Vector3d(0.0, 0.0, -1.0), setpoint.yaw_rad);
  debug_.v_sp_N_mps.setZero();
  debug_.a_sp_N_mps2.setZero();
  return UpdateAttitude(state, q_sp, ground_thrust_N_, 0.0, dt_s);
}

ControlOutput CascadedController::Update(const NavState& state, const Setpoint& setpoint, double dt_s) {
  if (setpoint.idle) {
    Reset();
    return ControlOutput();
  }
  if (setpoint.ground_ramp) return UpdateOnGround(state, setpoint, dt_s);
  if (setpoint.ground_contact) {
    // The rate integrators and the horizontal velocity integrators would wind up against the
    // ground's reaction and friction (ArduPilot soften_for_landing_xy relaxes the latter).
    for (Pid& p : rate_) p.set_integrator(0.0);
    vel_[0].set_integrator(0.0);
    vel_[1].set_integrator(0.0);
  }
  const ControllerParams& P = params_;
  const double m = vehicle_.mass_kg;

  // Position P → velocity setpoint, v_sp = v_ff + Kp·(p_sp − p), limited.
  Vector3d v_sp = setpoint.v_ff_N_mps;
  if (setpoint.position_valid) {
    const Vector3d e_p = setpoint.p_N_m - state.p_N_m;
    v_sp += Vector3d(P.pos_xy_kp * e_p.x(), P.pos_xy_kp * e_p.y(), P.pos_z_kp * e_p.z());
  }
  const double v_xy = v_sp.head<2>().norm();
  if (v_xy > P.max_speed_xy_mps) v_sp.head<2>() *= P.max_speed_xy_mps / v_xy;
  v_sp.z() = std::clamp(v_sp.z(), -P.max_speed_up_mps, P.max_speed_down_mps);

  // Velocity PID → acceleration setpoint.
  Vector3d a_sp;
  for (int i = 0; i < 3; ++i) a_sp[i] = vel_[i].Update(v_sp[i], state.v_N_mps[i], dt_s, setpoint.a_ff_N_mps2[i]);
  if (on_ground_) {
    // Lift-off: the vertical loop's integrator is set so that its output is the acceleration the
    // ground ramp's collective gives, a_D = g - T/m (bumpless, as ArduPilot's init_z_controller
    // seeds its I term from the throttle in use); the sequencer's carrot then moves it on.
    on_ground_ = false;
    const double a_D = kGravity_mps2 - ground_thrust_N_ / m;
    vel_[2].set_integrator(vel_[2].integrator() + a_D - a_sp.z());
    a_sp.z() = a_D;
  }

  // Thrust vector F = m·(a − g), g = +g·e_D; keep its vertical part first, then limit tilt and size.
  Vector3d F_N = m * (a_sp - Vector3d(0.0, 0.0, kGravity_mps2));
  const double T_min = P.min_thrust_fraction_of_weight * m * kGravity_mps2;
  double F_up = std::max(-F_N.z(), T_min);
  F_up = std::min(F_up, vehicle_.max_thrust_N);
  Eigen::Vector2d F_h = F_N.head<2>();
  double F_h_max = F_up * tan_max_tilt_;
  if (std::isfinite(vehicle_.max_thrust_N)) {
    F_h_max = std::min(F_h_max, std::sqrt(std::max(0.0, vehicle_.max_thrust_N * vehicle_.max_thrust_N - F_up * F_up)));
  }
  debug_.tilt_limited = F_h.norm() > F_h_max;
  if (debug_.tilt_limited) F_h *= F_h_max / F_h.norm();
  F_N = Vector3d(F_h.x(), F_h.y(), -F_up);

  const Quaterniond q_sp = AttitudeFromThrustAndYaw(F_N, setpoint.yaw_rad);
  // Collective: the thrust vector projected on the current body -z axis (less thrust while the
  // attitude is still far from the setpoint).
  const Vector3d z_B_N = state.q_NB.toRotationMatrix().col(2);
  const double thrust_N = std::clamp(-F_N.dot(z_B_N), 0.0, vehicle_.max_thrust_N);

  debug_.v_sp_N_mps = v_sp;
  debug_.a_sp_N_mps2 = a_sp;
  return UpdateAttitude(state, q_sp, thrust_N, setpoint.yaw_rate_ff_radps, dt_s);
}

ControlOutput CascadedController::UpdateAttitude(const NavState& state, const Quaterniond& q_sp_NB,
                                                 double thrust_N, double yaw_rate_ff_radps, double dt_s) {
  const ControllerParams& P = params_;
  const Quaterniond q = state.q_NB.normalized();
  Quaterniond qd = q_sp_NB.normalized();
  // Reduced attitude: the smallest rotation taking the current thrust axis to the desired one,
  // then yaw blended in with weight kp_yaw/kp_rollpitch (yaw de-prioritised, as PX4's AttitudeControl).
  const Vector3d e_z = q.toRotationMatrix().col(2);
  const Vector3d e_z_d = qd.toRotationMatrix().col(2);
  Quaterniond qd_red = Quaterniond::FromTwoVectors(e_z, e_z_d);
  if (std::abs(qd_red.x()) > 1.0 - 1e-5 || std::abs(qd_red.y()) > 1.0 - 1e-5) {
    qd_red = qd;  // 180° apart: the reduced rotation is undefined, go for the full attitude
  } else {
    qd_red = qd_red * q;
  }
  const double rp_kp = 0.5 * (P.att_roll_kp + P.att_pitch_kp);
  const double yaw_w = rp_kp > 0.0 ? std::clamp(P.att_yaw_kp / rp_kp, 0.0, 1.0) : 0.0;
  Quaterniond q_mix = qd_red.inverse() * qd;  // a pure yaw about body z
  if (q_mix.w() < 0.0) q_mix.coeffs() = -q_mix.coeffs();
  const double mw = std::clamp(q_mix.w(), -1.0, 1.0);
  const double mz = std::clamp(q_mix.z(), -1.0, 1.0);
  qd = qd_red * Quaterniond(std::cos(yaw_w * std::acos(mw)), 0.0, 0.0, std::sin(yaw_w * std::asin(mz)));

  Quaterniond qe = q.inverse() * qd;
  if (qe.w() < 0.0) qe.coeffs() = -qe.coeffs();
  const Vector3d eq = 2.0 * qe.vec();
  Vector3d w_sp(P.att_roll_kp * eq.x(), P.att_pitch_kp * eq.y(), rp_kp * eq.z());
  // The yaw weight already scaled the yaw error into roll/pitch gain units (PX4 does the same).
  w_sp += q.inverse() * Vector3d(0.0, 0.0, yaw_rate_ff_radps);
  const double max_rp = P.max_rate_rp_dps * kDegToRad;
  const double max_yaw = P.max_yaw_rate_dps * kDegToRad;
  w_sp.x() = std::clamp(w_sp.x(), -max_rp, max_rp);
  w_sp.y() = std::clamp(w_sp.y(), -max_rp, max_rp);
  w_sp.z() = std::clamp(w_sp.z(), -max_yaw, max_yaw);

  debug_.q_sp_NB = q_sp_NB;
  debug_.w_sp_B_radps = w_sp;
  ControlOutput out;
  out.thrust_N = thrust_N;
  out.torque_B_Nm = UpdateRates(state, w_sp, dt_s);
  return out;
}

Vector3d CascadedController::UpdateRates(const NavState& state, const Vector3d& w_sp_B_radps, double dt_s) {
  Vector3d alpha;
  for (int i = 0; i < 3; ++i) alpha[i] = rate_[i].Update(w_sp_B_radps[i], state.w_B_radps[i], dt_s);
  debug_.alpha_sp_B_radps2 = alpha;
  const Matrix3d& J = vehicle_.inertia_kgm2;
  const Vector3d& w = state.w_B_radps;
  return J * alpha + w.cross(J * w);  // τ = J·α + ω×Jω
}

}  // namespace hexsim::control
