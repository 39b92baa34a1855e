// The autopilot stage: estimator (fed the compensated compass), mission sequencer, setpoint hook,
// controller, output hook, mixer and the motor commands, run on each fresh IMU sample.
#include <algorithm>

#include "stages.h"

namespace hexsim::sim {

std::vector<control::RotorGeometry> MixerGeometry(const vehicle::VehicleParams& v) {
  std::vector<control::RotorGeometry> g;
  for (const auto& r : v.rotors) {
    control::RotorGeometry rg;
    rg.p_B_m = r.position_B_m;
    rg.thrust_axis_B = r.axis_B;
    rg.spin = r.spin;
    rg.torque_to_thrust_m = r.k_T_Nprps2 > 0 ? r.k_Q_Nmprps2 / r.k_T_Nprps2 : 0.0;
    g.push_back(rg);
  }
  return g;
}

namespace {
// ThrustForCommand depends on the rotor through k_T and k_Q only.
bool SamePropeller(const vehicle::RotorParams& a, const vehicle::RotorParams& b) {
  return a.k_T_Nprps2 == b.k_T_Nprps2 && a.k_Q_Nmprps2 == b.k_Q_Nmprps2;
}
}  // namespace

control::VehicleModelForControl ControlModelFor(const vehicle::VehicleParams& vehicle) {
  const vehicle::VehicleParams& vp = vehicle;
  const double nominal_V = vp.battery.OpenCircuitVoltage_V(vp.battery.initial_soc);
  double max_rotor_thrust_N = 0.0;
  for (size_t i = 0; i < vp.rotors.size(); ++i) {
    max_rotor_thrust_N = std::max(max_rotor_thrust_N, vehicle::ThrustForCommand(vp, i, 1.0, nominal_V));
  }
  return control::VehicleModelForControl{vp.mass_kg, vp.inertia_kgm2,
                                         max_rotor_thrust_N * static_cast<double>(vp.rotors.size())};
}

Autopilot::Autopilot(const RunSetup& setup, Plugins plugins, const magnetics::EarthField& field, double rest_D_m,
                     const Eigen::Vector3d& start_N_m)
    : vp_(setup.vehicle), opt_(setup.options), spool_(setup.vehicle.esc.spool_up_time_s) {
  nominal_V_ = vp_.battery.OpenCircuitVoltage_V(vp_.battery.initial_soc);
  model_ = ControlModelFor(vp_);
  mixer_.emplace(control::Mixer::Create(MixerGeometry(vp_)).value());
  if (plugins.controller) {
    controller_ = std::move(plugins.controller);
  } else {
    auto cascade = std::make_unique<control::CascadedController>(setup.control, model_);
    builtin_ = cascade.get();
    controller_ = std::move(cascade);
  }
  control::SequencerParams seq_params;
  seq_params.ground_D_m = rest_D_m;
  sequencer_.emplace(setup.mission, seq_params);
  path_ = control::PlannedPath(setup.mission, start_N_m, rest_D_m);

  compensator_ = setup.compensator;
  estimator_name_ = opt_.estimator;
  if (plugins.estimator) {
    estimator_ = std::move(plugins.estimator);
    estimator_name_ = estimator_->name();
  } else if (opt_.estimator != "truth") {
    nav::NavParams np = setup.nav;
    np.estimator = opt_.estimator;
    np.earth.B_N_uT = field.B_N_uT;  // the autopilot knows the model field, not the local anomaly
    estimator_ = nav::MakeEstimator(opt_.estimator, np).value();
  }
  if (estimator_) {
    nav::NavEstimate init;
    init.p_N_m = start_N_m;
    init.healthy = false;  // static alignment on the ground
    estimator_->Reset(init);
  }
  setpoint_hook_ = std::move(plugins.setpoint_hook);
  output_hook_ = std::move(plugins.output_hook);
  command_hook_ = std::move(plugins.command_hook);
  commands_.assign(vp_.rotors.size(), 0.0);
}

Autopilot::Tick Autopilot::Step(double t, double physics_dt_s, const vehicle::SensorReadings& rd, const BodyState& s,
                                double bus_V, double battery_A) {
  Tick tick;
  pending_mag_ = pending_mag_ || (!rd.mag_uT.empty() && rd.mag_uT[0].fresh);
  pending_gps_ = pending_gps_ || rd.gps.fresh;
  pending_baro_ = pending_baro_ || rd.baro.fresh;
  if (!rd.gyro_radps.fresh) return tick;
  tick.ran = true;
  const size_t n_rotors = commands_.size();
  const double ap_dt = last_imu_t_s_ < 0 ? physics_dt_s : rd.gyro_radps.t_s - last_imu_t_s_;
  last_imu_t_s_ = rd.gyro_radps.t_s;
  ns_.t_s = t;
  if (!estimator_) {
    ns_.p_N_m = s.p_N_m;
    ns_.v_N_mps = s.v_N_mps;
    ns_.q_NB = s.q_NB;
    ns_.w_B_radps = s.w_B_radps;
    est_.t_s = t;
    est_.p_N_m = s.p_N_m;
    est_.v_N_mps = s.v_N_mps;
    est_.q_NB = s.q_NB;
    est_.w_B_radps = s.w_B_radps;
  } else {
    estimator_->PredictImu({rd.gyro_radps.t_s, rd.gyro_radps.value, rd.accel_mps2.value});
    // The readings hold their latest sample, so a pending one is still in `rd`.
    if (pending_mag_) {
      Eigen::Vector3d m = rd.mag_uT[0].value;
      if (compensator_) m = compensator_->Correct(m, {control_u_, battery_A});
      estimator_->FuseMag({rd.mag_uT[0].t_s, m});
    }
    if (pending_gps_) estimator_->FuseGps({rd.gps.t_s, rd.gps.p_N_m, rd.gps.v_N_mps});
    if (pending_baro_) estimator_->FuseBaro({rd.baro.t_s, rd.baro.alt_m});
    pending_mag_ = pending_gps_ = pending_baro_ = false;
    est_ = estimator_->Estimate();
    const Status h = estimator_->Health();
    if (!h.ok()) {
      tick.failure = "estimator: " + h.message();
      return tick;
    }
    const bool from_est = !opt_.control_on_truth;
    ns_.p_N_m = from_est ? est_.p_N_m : s.p_N_m;
    ns_.v_N_mps = from_est ? est_.v_N_mps : s.v_N_mps;
    ns_.q_NB = from_est ? est_.q_NB : s.q_NB;
    ns_.w_B_radps = from_est ? est_.w_B_radps : s.w_B_radps;
  }
  // The mission starts once the estimator has aligned on the ground (as an autopilot refuses to
  // arm before its EKF is healthy); until then the motors stay off.
  const bool armed = !estimator_ || opt_.control_on_truth || est_.healthy || !sequencer_->landed();
  if (armed) {
    // The last collective against the vehicle's weight (lift-off and touchdown need it).
    const double collective_to_weight = spool_.mixing() ? u_.thrust_N / (model_.mass_kg * kGravity_mps2) : 0.0;
    seq_out_ = sequencer_->Step(ns_, ap_dt, spool_.mixing(), collective_to_weight);
  } else {
    seq_out_ = control::SequencerOutput{};
    seq_out_.setpoint.idle = true;
  }
  tick.payload_event = seq_out_.payload_event;
  if (seq_out_.arrival) tick.arrival = &*seq_out_.arrival;
  if (setpoint_hook_) setpoint_hook_(t, ns_, &seq_out_.setpoint);
  // Rotors with the same propeller and motor reach the same full-command thrust: computed once.
  double max_thrust = 0.0, rotor_max_N = 0.0;
  for (size_t i = 0; i < n_rotors; ++i) {
    if (i == 0 || !SamePropeller(vp_.rotors[i], vp_.rotors[i - 1])) {
      rotor_max_N = vehicle::ThrustForCommand(vp_, i, 1.0, bus_V);
    }
    max_thrust = std::max(max_thrust, rotor_max_N);
  }
  const double max_collective_N = max_thrust * static_cast<double>(n_rotors);
  const bool run = !seq_out_.setpoint.idle;
  if (run && spool_.mixing()) {
    u_ = controller_->Update(ns_, seq_out_.setpoint, ap_dt);
    if (output_hook_) output_hook_(t, ns_, &u_);
  } else {
    controller_->Reset();
    u_ = control::ControlOutput{};
  }
  // The output stage (control/spool.h, ArduPilot MOT_SPOOL_TIME): idle, then the collective capped
  // while spooling; roll/pitch/yaw are mixed on top of the capped collective.
  spool_.Step(run, max_collective_N > 0.0 ? u_.thrust_N / max_collective_N : 0.0, ap_dt);
  if (!spool_.spinning()) {
    std::fill(commands_.begin(), commands_.end(), 0.0);
  } else if (!spool_.mixing()) {
    std::fill(commands_.begin(), commands_.end(), vehicle::kIdleCommand);
  } else if (run) {
    const double collective_N = std::min(u_.thrust_N, spool_.collective_cap() * max_collective_N);
    mixer_->Mix(collective_N, u_.torque_B_Nm, max_thrust, &mix_);
    for (size_t i = 0; i < n_rotors; ++i) {
      commands_[i] = vehicle::CommandForThrust(vp_, i, mix_.thrust_N[static_cast<Eigen::Index>(i)], bus_V);
    }
  } else {
    // Spooling down after touchdown, the controller off: every rotor's thrust falls with the cap.
    for (size_t i = 0; i < n_rotors; ++i) {
      const double cap = vehicle::CommandForThrust(vp_, i, spool_.collective_cap() * max_thrust, bus_V);
      commands_[i] = std::max(vehicle::kIdleCommand, std::min(commands_[i], cap));
    }
  }
  if (command_hook_) {
    command_hook_(t, ns_, &commands_);
    for (double& c : commands_) c = std::clamp(c, 0.0, 1.0);
  }
  control_u_ = control::ControlAmount(Eigen::Map<const Eigen::VectorXd>(commands_.data(), commands_.size()));
  return tick;
}

}  // namespace hexsim::sim
