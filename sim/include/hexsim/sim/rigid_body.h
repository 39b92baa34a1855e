// The vehicle's rigid body in an ODE world: gravity, a ground plane with contact, and forces applied
// each step. Only sim/ knows ODE; this header keeps it private (PIMPL).
#pragma once

#include <memory>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace hexsim::sim {

struct RigidBodyParams {
  double mass_kg = 1.0;
  Eigen::Matrix3d inertia_kgm2 = Eigen::Matrix3d::Identity() * 0.01;
  // Landing-gear box below the centre of mass (size and offset in body FRD).
  Eigen::Vector3d gear_size_m = Eigen::Vector3d(0.5, 0.5, 0.05);
  Eigen::Vector3d gear_offset_B_m = Eigen::Vector3d(0.0, 0.0, 0.15);
  double ground_friction = 0.8;
  double gravity_mps2 = 9.80665;
};

struct BodyState {
  Eigen::Vector3d p_N_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_N_mps = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_NB = Eigen::Quaterniond::Identity();
  Eigen::Vector3d w_B_radps = Eigen::Vector3d::Zero();
};

class RigidBodyWorld {
 public:
  // `ground` false: free space, no ground plane (for physics-law tests).
  RigidBodyWorld(const RigidBodyParams& params, const BodyState& initial, bool ground = true);
  ~RigidBodyWorld();
  RigidBodyWorld(const RigidBodyWorld&) = delete;
  RigidBodyWorld& operator=(const RigidBodyWorld&) = delete;

  BodyState State() const;
  // Forces and torques accumulate until the next Step (body-frame ones are summed and rotated into N
  // with the attitude at the step).
  void AddForce_B(const Eigen::Vector3d& force_B_N);
  void AddForce_N(const Eigen::Vector3d& force_N_N);
  void AddTorque_B(const Eigen::Vector3d& torque_B_Nm);
  // Collides with the ground, steps the world by dt (dWorldStep: direct, deterministic).
  void Step(double dt_s);
  // Changes mass and inertia (payload attach/release), keeping the state.
  void SetMassProperties(double mass_kg, const Eigen::Matrix3d& inertia_kgm2);
  // Puts the body at a state (teleport), e.g. for a rig.
  void SetState(const BodyState& state);
  int contact_count() const;
  double mass_kg() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Calls dInitODE2 once per process (thread-safe).
void EnsureOdeInitialised();

}  // namespace hexsim::sim
