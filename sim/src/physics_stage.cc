// The sensor and physics stages: sampling the truth, and one physics step (powertrain, rotor
// wrench and aerodynamics, airframe drag, wind, external force, ODE).
#include <fmt/format.h>

#include "stages.h"
#include "hexsim/vehicle/rotor_aero.h"
#include "hexsim/vehicle/rotor_wrench.h"

namespace hexsim::sim {

namespace {

bool Finite(const BodyState& s) {
  return s.p_N_m.allFinite() && s.v_N_mps.allFinite() && s.q_NB.coeffs().allFinite() && s.w_B_radps.allFinite();
}

std::string NonFiniteQuantity(const BodyState& s) {
  if (!s.p_N_m.allFinite()) return "position";
  if (!s.v_N_mps.allFinite()) return "velocity";
  if (!s.q_NB.coeffs().allFinite()) return "attitude";
  return "angular rate";
}

}  // namespace

double RestingHeight_m(const RigidBodyParams& body) { return body.gear_offset_B_m.z() + 0.5 * body.gear_size_m.z(); }

// Landing gear: a box under the centre of mass, as wide as half the rotor circle.
RigidBodyParams BodyParamsFor(const vehicle::VehicleParams& v, const WorldParams& w, double payload_kg) {
  RigidBodyParams p;
  p.mass_kg = v.mass_kg + payload_kg;
  p.inertia_kgm2 = v.inertia_kgm2;
  double arm_m = 0.1;
  for (const auto& r : v.rotors) arm_m = std::max(arm_m, r.position_B_m.head<2>().norm());
  p.gear_size_m = Eigen::Vector3d(arm_m, arm_m, 0.05);
  p.gear_offset_B_m = Eigen::Vector3d(0, 0, 0.15);
  p.ground_friction = w.ground_friction;
  return p;
}

// --- SensorStage ---------------------------------------------------------------------------------

SensorStage::SensorStage(const vehicle::VehicleParams& vp, uint64_t seed, const Eigen::Vector3d& B_earth_N_uT)
    : avionics_A_(vp.avionics_current_A) {
  suite_.emplace(vehicle::SensorSuite::Create(vp, seed).value());
  truth_.B_earth_N_uT = B_earth_N_uT;
  truth_.currents.battery_A = vp.avionics_current_A;
  truth_.currents.motor_A.assign(vp.rotors.size(), 0.0);
  empty_.mag_uT.resize(vp.compasses.size());
}

const vehicle::SensorReadings& SensorStage::Sample(double t, const BodyState& s, const Eigen::Vector3d& f_B,
                                                   const vehicle::PowertrainOutput& pt) {
  truth_.t_s = t;
  truth_.p_N_m = s.p_N_m;
  truth_.v_N_mps = s.v_N_mps;
  truth_.q_NB = s.q_NB;
  truth_.w_B_radps = s.w_B_radps;
  truth_.specific_force_B_mps2 = f_B;
  if (pt.motors.empty()) {
    truth_.currents.battery_A = avionics_A_;
    std::fill(truth_.currents.motor_A.begin(), truth_.currents.motor_A.end(), 0.0);
  } else {
    truth_.currents.battery_A = pt.battery_A;
    for (size_t i = 0; i < truth_.currents.motor_A.size(); ++i) truth_.currents.motor_A[i] = pt.motors[i].dc_A;
  }
  rd_ = &suite_->Step(truth_);
  return *rd_;
}

// --- PhysicsStage --------------------------------------------------------------------------------

PhysicsStage::PhysicsStage(const RunSetup& setup, uint64_t seed)
    : vp_(setup.vehicle), world_(setup.world), rotor_wrench_(setup.vehicle) {
  WindParams wind_params = setup.world.wind;
  if (setup.mission.wind) {
    wind_params.mean_N_mps = setup.mission.wind->mean_N_mps;
    wind_params.turbulence_std_mps = setup.mission.wind->gust_std_mps;
  }
  wind_.emplace(wind_params, seed);
  payload_kg_ = setup.mission.payload_kg;
  const RigidBodyParams body_params = BodyParamsFor(vp_, world_, payload_kg_);
  rest_D_m_ = -RestingHeight_m(body_params);
  start_.p_N_m = Eigen::Vector3d(0, 0, rest_D_m_);
  body_ = std::make_unique<RigidBodyWorld>(body_params, start_, /*ground=*/true);
  power_ = vehicle::InitialPowertrainState(vp_);
  pt_.motors.reserve(vp_.rotors.size());
  s_ = body_->State();
  p_prev_N_m_ = s_.p_N_m;
}

void PhysicsStage::SetPayload_kg(double payload_kg) {
  payload_kg_ = payload_kg;
  // Point mass at the attachment point, CG kept at the body origin (parallel-axis inertia).
  const Eigen::Vector3d r = vp_.payload.attach_B_m;
  const Eigen::Matrix3d I_payload = payload_kg_ * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
  body_->SetMassProperties(BodyParamsFor(vp_, world_, payload_kg_).mass_kg, vp_.inertia_kgm2 + I_payload);
}

std::string PhysicsStage::Advance(const std::vector<double>& commands, double t, double dt) {
  vehicle::StepPowertrain(vp_, commands, dt, &power_, &pt_);
  // Every body-frame force and torque is summed here and handed to ODE once.
  vehicle::Wrench w_B = rotor_wrench_(power_.omega_radps, s_.w_B_radps);
  const Eigen::Vector3d wind_N = wind_->Step(dt);
  const Eigen::Vector3d v_air_B = s_.q_NB.conjugate() * (s_.v_N_mps - wind_N);
  const auto& d = vp_.drag;
  w_B.force_B_N -= d.linear_Nspm.cwiseProduct(v_air_B) +
                   d.quadratic_Ns2pm2.cwiseProduct(v_air_B.cwiseAbs().cwiseProduct(v_air_B));
  w_B.torque_B_Nm -= d.rotational_Nmsprad.cwiseProduct(s_.w_B_radps) +
                     d.rotational_quad_Nms2prad2.cwiseProduct(s_.w_B_radps.cwiseAbs().cwiseProduct(s_.w_B_radps));
  // Optional rotor aerodynamics (vehicle `aero:`; off by default, and then nothing is added).
  if (vehicle::RotorAeroEnabled(vp_.aero)) {
    const vehicle::Wrench aero = vehicle::RotorAeroWrench(vp_, power_.omega_radps, v_air_B, s_.p_N_m.z(), s_.q_NB);
    w_B.force_B_N += aero.force_B_N;
    w_B.torque_B_Nm += aero.torque_B_Nm;
  }
  body_->AddForce_B(w_B.force_B_N);
  body_->AddTorque_B(w_B.torque_B_Nm);
  if (!external_force_N_N_.isZero()) body_->AddForce_N(external_force_N_N_);
  body_->Step(dt);
  const BodyState next = body_->State();
  if (!Finite(next)) return fmt::format("non-finite {} at t = {:.3f} s", NonFiniteQuantity(next), t + dt);
  if (next.p_N_m.norm() > 1e5 || next.v_N_mps.norm() > 500.0) {
    return fmt::format("{} out of bounds at t = {:.3f} s", next.v_N_mps.norm() > 500.0 ? "velocity" : "position",
                       t + dt);
  }
  // Specific force: what an accelerometer at the CG measures, f = a − g (includes ground contact).
  const Eigen::Vector3d a_N = (next.v_N_mps - s_.v_N_mps) / dt;
  specific_force_B_ = next.q_NB.conjugate() * (a_N - Eigen::Vector3d(0, 0, kGravity_mps2));
  p_prev_N_m_ = s_.p_N_m;
  s_ = next;
  return "";
}

}  // namespace hexsim::sim
