#include "support/plant.h"

#include <algorithm>

#include "hexsim/common/rotation.h"

namespace hexsim::control::testing {

using Eigen::Vector3d;

std::vector<RotorGeometry> HexLayout() { return CircularLayout(6, 0.6, 30.0, 1); }
std::vector<RotorGeometry> QuadLayout() { return CircularLayout(4, 0.25, 45.0, 1); }

RigidBodyPlant::RigidBodyPlant(const PlantParams& params, Mixer mixer)
    : params_(params), mixer_(std::move(mixer)), mass_kg_(params.mass_kg) {
  const int n = mixer_.rotor_count();
  max_rotor_thrust_N_ = params.max_rotor_thrust_N > 0.0 ? params.max_rotor_thrust_N
                                                        : 2.0 * params.mass_kg * kGravity_mps2 / n;
  rotor_thrust_N_ = Eigen::VectorXd::Zero(n);
}

void RigidBodyPlant::Step(const ControlOutput& command, double dt_s) {
  last_mix_ = mixer_.Mix(command.thrust_N, command.torque_B_Nm, max_rotor_thrust_N_);
  const double a = dt_s / (params_.rotor_tau_s + dt_s);
  rotor_thrust_N_ += a * (last_mix_.thrust_N - rotor_thrust_N_);
  const Eigen::Vector4d w = mixer_.allocation() * rotor_thrust_N_;
  StepWrench(w(0), w.tail<3>(), dt_s);
}

void RigidBodyPlant::StepWrench(double thrust_N, const Vector3d& torque_B_Nm, double dt_s) {
  NavState& s = state_;
  const Eigen::Matrix3d R_NB = s.q_NB.toRotationMatrix();
  const Eigen::Matrix3d& J = params_.inertia_kgm2;
  // m·v̇ = R·(0,0,−T) + m·g·e_D − c·v ;  J·ω̇ = τ − ω×Jω
  const Vector3d F_N = R_NB * Vector3d(0.0, 0.0, -thrust_N) + Vector3d(0.0, 0.0, mass_kg_ * kGravity_mps2) -
                       params_.drag_Nspmps * s.v_N_mps;
  const Vector3d w_dot = J.ldlt().solve(torque_B_Nm - s.w_B_radps.cross(J * s.w_B_radps));
  s.v_N_mps += F_N / mass_kg_ * dt_s;
  s.w_B_radps += w_dot * dt_s;
  s.p_N_m += s.v_N_mps * dt_s;
  s.q_NB = (s.q_NB * QuatExp(s.w_B_radps * dt_s)).normalized();
  s.t_s += dt_s;
  on_ground_ = false;
  if (params_.ground && s.p_N_m.z() >= 0.0) {
    // Resting on flat ground: no penetration, friction stops sliding and rotation, attitude level
    // (keeping heading).
    on_ground_ = true;
    s.p_N_m.z() = 0.0;
    if (s.v_N_mps.z() > 0.0) s.v_N_mps.setZero();
    s.v_N_mps.head<2>().setZero();
    s.w_B_radps.setZero();
    s.q_NB = QuatFromEuler(0.0, 0.0, EulerFromQuat(s.q_NB).z());
  }
}

}  // namespace hexsim::control::testing
