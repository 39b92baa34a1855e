#include "hexsim/sim/rigid_body.h"

#include <cmath>
#include <mutex>

#include <ode/ode.h>
#include <ode/threading_impl.h>

#include "hexsim/common/status.h"

namespace hexsim::sim {

void EnsureOdeInitialised() {
  static std::once_flag once;
  std::call_once(once, [] { dInitODE2(0); });
  dAllocateODEDataForThread(dAllocateMaskAll);
}

struct RigidBodyWorld::Impl {
  dWorldID world = nullptr;
  // Each world has its own (single-threaded) stepping implementation: ODE's default one is shared
  // by every world in the process and is not safe when worlds step on different threads.
  dThreadingImplementationID threading = nullptr;
  dSpaceID space = nullptr;
  dJointGroupID contacts = nullptr;
  dBodyID body = nullptr;
  dGeomID gear = nullptr;
  dGeomID ground = nullptr;
  double friction = 0.8;
  Eigen::Vector3d gear_half_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d gear_offset_B_m = Eigen::Vector3d::Zero();
  // State() read back from ODE, valid until the body next moves (Step, SetState): the loop reads
  // the state after each step and the explicit gyroscopic term reads it again before the next.
  BodyState state_cache;
  bool state_cache_valid = false;
  int contact_count = 0;
  double mass_kg = 1.0;
  bool explicit_gyro = true;
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d inertia_inv = Eigen::Matrix3d::Identity();
  // Body-frame force and torque added since the last step, handed to ODE once in Step().
  Eigen::Vector3d force_B_N = Eigen::Vector3d::Zero();
  Eigen::Vector3d torque_B_Nm = Eigen::Vector3d::Zero();
};

namespace {
constexpr int kMaxContacts = 8;

void SetMass(dBodyID body, double mass_kg, const Eigen::Matrix3d& I) {
  dMass m;
  dMassSetParameters(&m, mass_kg, 0, 0, 0, I(0, 0), I(1, 1), I(2, 2), I(0, 1), I(0, 2), I(1, 2));
  dBodySetMass(body, &m);
}
}  // namespace

RigidBodyWorld::RigidBodyWorld(const RigidBodyParams& params, const BodyState& initial, bool ground)
    : impl_(std::make_unique<Impl>()) {
  EnsureOdeInitialised();
  Impl& w = *impl_;
  w.world = dWorldCreate();
  w.threading = dThreadingAllocateSelfThreadedImplementation();
  dWorldSetStepThreadingImplementation(w.world, dThreadingImplementationGetFunctions(w.threading), w.threading);
  // One body, one island: no point in asking the stepper for island-level parallelism.
  dWorldSetStepIslandsProcessingMaxThreadCount(w.world, 1);
  // NED: gravity points along +D.
  dWorldSetGravity(w.world, 0, 0, params.gravity_mps2);
  dWorldSetERP(w.world, 0.2);
  dWorldSetCFM(w.world, 1e-6);
  dWorldSetAutoDisableFlag(w.world, 0);
  w.space = dSimpleSpaceCreate(nullptr);
  w.contacts = dJointGroupCreate(0);
  w.body = dBodyCreate(w.world);
  w.mass_kg = params.mass_kg;
  dBodySetGyroscopicMode(w.body, 0);
  dBodySetFiniteRotationMode(w.body, 1);  // exact rotation update for the step's rate
  SetMassProperties(params.mass_kg, params.inertia_kgm2);
  w.gear = dCreateBox(w.space, params.gear_size_m.x(), params.gear_size_m.y(), params.gear_size_m.z());
  dGeomSetBody(w.gear, w.body);
  dGeomSetOffsetPosition(w.gear, params.gear_offset_B_m.x(), params.gear_offset_B_m.y(), params.gear_offset_B_m.z());
  if (ground) {
    // Plane a·x + b·y + c·z = d with the normal pointing into free space: up is −D.
    w.ground = dCreatePlane(w.space, 0, 0, -1, 0);
  }
  w.friction = params.ground_friction;
  w.gear_half_m = 0.5 * params.gear_size_m;
  w.gear_offset_B_m = params.gear_offset_B_m;
  SetState(initial);
}

RigidBodyWorld::~RigidBodyWorld() {
  dJointGroupDestroy(impl_->contacts);
  dSpaceDestroy(impl_->space);  // destroys its geoms
  dWorldSetStepThreadingImplementation(impl_->world, nullptr, nullptr);
  dWorldDestroy(impl_->world);
  dThreadingFreeImplementation(impl_->threading);
}

void RigidBodyWorld::SetState(const BodyState& s) {
  impl_->state_cache_valid = false;
  dBodySetPosition(impl_->body, s.p_N_m.x(), s.p_N_m.y(), s.p_N_m.z());
  const Eigen::Quaterniond q = s.q_NB.normalized();
  const dQuaternion dq = {q.w(), q.x(), q.y(), q.z()};
  dBodySetQuaternion(impl_->body, dq);
  dBodySetLinearVel(impl_->body, s.v_N_mps.x(), s.v_N_mps.y(), s.v_N_mps.z());
  const Eigen::Vector3d w_N = q * s.w_B_radps;
  dBodySetAngularVel(impl_->body, w_N.x(), w_N.y(), w_N.z());
}

BodyState RigidBodyWorld::State() const {
  if (impl_->state_cache_valid) return impl_->state_cache;
  BodyState s;
  const dReal* p = dBodyGetPosition(impl_->body);
  const dReal* q = dBodyGetQuaternion(impl_->body);
  const dReal* v = dBodyGetLinearVel(impl_->body);
  const dReal* w = dBodyGetAngularVel(impl_->body);
  s.p_N_m = {p[0], p[1], p[2]};
  s.q_NB = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
  s.v_N_mps = {v[0], v[1], v[2]};
  s.w_B_radps = s.q_NB.conjugate() * Eigen::Vector3d(w[0], w[1], w[2]);
  impl_->state_cache = s;
  impl_->state_cache_valid = true;
  return s;
}

void RigidBodyWorld::AddForce_B(const Eigen::Vector3d& f) { impl_->force_B_N += f; }
void RigidBodyWorld::AddForce_N(const Eigen::Vector3d& f) { dBodyAddForce(impl_->body, f.x(), f.y(), f.z()); }
void RigidBodyWorld::AddTorque_B(const Eigen::Vector3d& t) { impl_->torque_B_Nm += t; }

void RigidBodyWorld::Step(double dt_s) {
  Impl& w = *impl_;
  w.contact_count = 0;
  // The plane reports a contact for every box corner at D >= 0: while the lowest corner of the gear
  // is well above the ground (by kClearance_m, far beyond rounding), the collision test would find
  // nothing and is skipped.
  constexpr double kClearance_m = 0.01;
  bool near_ground = false;
  if (w.ground) {
    const dReal* p = dBodyGetPosition(w.body);
    const dReal* R = dBodyGetRotation(w.body);  // 3×4 row-major; row 2 is the D axis
    const Eigen::Vector3d& o = w.gear_offset_B_m;
    const double centre_D = p[2] + R[8] * o.x() + R[9] * o.y() + R[10] * o.z();
    const double reach_D = std::abs(R[8]) * w.gear_half_m.x() + std::abs(R[9]) * w.gear_half_m.y() +
                           std::abs(R[10]) * w.gear_half_m.z();
    near_ground = !(centre_D + reach_D < -kClearance_m);  // NaN: let ODE see it
  }
  if (near_ground) {
    dContactGeom geoms[kMaxContacts];
    const int n = dCollide(w.gear, w.ground, kMaxContacts, geoms, sizeof(dContactGeom));
    for (int i = 0; i < n; ++i) {
      dContact c{};
      c.surface.mode = dContactSoftERP | dContactSoftCFM | dContactApprox1;
      c.surface.mu = w.friction;
      c.surface.soft_erp = 0.2;
      c.surface.soft_cfm = 1e-5;
      c.geom = geoms[i];
      dJointID j = dJointCreateContact(w.world, w.contacts, &c);
      dJointAttach(j, w.body, nullptr);
    }
    w.contact_count = n;
  }
  if (w.explicit_gyro) {
    // −ω × (J·ω), evaluated with the midpoint rate predicted from this torque (second order),
    // in place of ODE's implicit gyroscopic step, which damps a free spin by ~1 % in 3 s.
    const BodyState s = State();
    const Eigen::Vector3d w0 = s.w_B_radps;
    const Eigen::Vector3d wdot = -w.inertia_inv * w0.cross(w.inertia * w0);
    const Eigen::Vector3d wm = w0 + 0.5 * dt_s * wdot;
    w.torque_B_Nm -= wm.cross(w.inertia * wm);
  }
  // The body-frame sums, rotated into N by ODE once each.
  dBodyAddRelForce(w.body, w.force_B_N.x(), w.force_B_N.y(), w.force_B_N.z());
  dBodyAddRelTorque(w.body, w.torque_B_Nm.x(), w.torque_B_Nm.y(), w.torque_B_Nm.z());
  w.force_B_N.setZero();
  w.torque_B_Nm.setZero();
  w.state_cache_valid = false;
  dWorldStep(w.world, dt_s);
  dJointGroupEmpty(w.contacts);
}

void RigidBodyWorld::SetMassProperties(double mass_kg, const Eigen::Matrix3d& inertia_kgm2) {
  SetMass(impl_->body, mass_kg, inertia_kgm2);
  impl_->mass_kg = mass_kg;
  impl_->inertia = inertia_kgm2;
  impl_->inertia_inv = inertia_kgm2.inverse();
}

int RigidBodyWorld::contact_count() const { return impl_->contact_count; }
double RigidBodyWorld::mass_kg() const { return impl_->mass_kg; }

}  // namespace hexsim::sim
