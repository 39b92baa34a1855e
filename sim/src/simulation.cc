#include "hexsim/sim/simulation.h"

#include <array>
#include <chrono>
#include <cmath>
#include <optional>

#include <fmt/format.h>

#include "hexsim/common/paths.h"
#include "hexsim/common/rotation.h"
#include "hexsim/control/mixer.h"
#include "hexsim/control/sequencer.h"
#include "hexsim/magnetics/wmm.h"
#include "hexsim/sim/rigid_body.h"
#include "hexsim/vehicle/powertrain.h"
#include "hexsim/vehicle/sensors.h"

namespace hexsim::sim {

namespace {

// Landing gear: a box under the centre of mass, as wide as half the rotor circle.
RigidBodyParams BodyParamsFor(const vehicle::VehicleParams& v, const WorldParams& w) {
  RigidBodyParams p;
  p.mass_kg = v.mass_kg + v.payload.mass_kg;
  p.inertia_kgm2 = v.inertia_kgm2;
  double arm_m = 0.1;
  for (const auto& r : v.rotors) arm_m = std::max(arm_m, r.position_B_m.head<2>().norm());
  p.gear_size_m = Eigen::Vector3d(arm_m, arm_m, 0.05);
  p.gear_offset_B_m = Eigen::Vector3d(0, 0, 0.15);
  p.ground_friction = w.ground_friction;
  return p;
}

double RestingHeight_m(const RigidBodyParams& p) { return p.gear_offset_B_m.z() + 0.5 * p.gear_size_m.z(); }

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

// Columns of the FlightLog, looked up once.
struct LogColumns {
  size_t t, pos[3], vel[3], q[4], gyro[3], accel[3], baro, baro_t, gps[3], gps_vel[3], gps_t;
  size_t control_u, current, voltage, soc;
  std::vector<size_t> motor_u, motor_A;
  std::vector<std::array<size_t, 4>> mag;  // x, y, z, t per compass
  size_t est_q[4], est_pos[3], est_vel[3], yaw_true, yaw_est, mode, wp, wind[3], payload;

  LogColumns(logs::FlightLog* log, size_t rotors, size_t compasses) {
    auto add = [&](const std::string& n) { return log->AddColumn(n); };
    t = add("t_s");
    const char* ned[3] = {"N", "E", "D"};
    const char* xyz[3] = {"x", "y", "z"};
    for (int i = 0; i < 3; ++i) pos[i] = add(fmt::format("pos_{}_m", ned[i]));
    for (int i = 0; i < 3; ++i) vel[i] = add(fmt::format("vel_{}_mps", ned[i]));
    const char* wxyz[4] = {"w", "x", "y", "z"};
    for (int i = 0; i < 4; ++i) q[i] = add(fmt::format("q_{}", wxyz[i]));
    for (int i = 0; i < 3; ++i) gyro[i] = add(fmt::format("gyro_{}_radps", xyz[i]));
    for (int i = 0; i < 3; ++i) accel[i] = add(fmt::format("accel_{}_mps2", xyz[i]));
    for (size_t c = 0; c < compasses; ++c) {
      const std::string pre = c == 0 ? "mag" : fmt::format("mag{}", c + 1);
      mag.push_back({add(pre + "_x_uT"), add(pre + "_y_uT"), add(pre + "_z_uT"), add(pre + "_t_s")});
    }
    baro = add("baro_alt_m");
    baro_t = add("baro_t_s");
    for (int i = 0; i < 3; ++i) gps[i] = add(fmt::format("gps_{}_m", ned[i]));
    for (int i = 0; i < 3; ++i) gps_vel[i] = add(fmt::format("gps_vel_{}_mps", ned[i]));
    gps_t = add("gps_t_s");
    control_u = add("control_u");
    current = add("current_A");
    voltage = add("voltage_V");
    soc = add("battery_soc");
    for (size_t i = 0; i < rotors; ++i) motor_u.push_back(add(fmt::format("motor_{}_u", i + 1)));
    for (size_t i = 0; i < rotors; ++i) motor_A.push_back(add(fmt::format("motor_{}_A", i + 1)));
    for (int i = 0; i < 4; ++i) est_q[i] = add(fmt::format("est_q_{}", wxyz[i]));
    for (int i = 0; i < 3; ++i) est_pos[i] = add(fmt::format("est_pos_{}_m", ned[i]));
    for (int i = 0; i < 3; ++i) est_vel[i] = add(fmt::format("est_vel_{}_mps", ned[i]));
    yaw_true = add("yaw_true_deg");
    yaw_est = add("yaw_est_deg");
    mode = add("mode");
    wp = add("waypoint_index");
    for (int i = 0; i < 3; ++i) wind[i] = add(fmt::format("wind_{}_mps", ned[i]));
    payload = add("payload_kg");
  }
};

struct Stats {
  double n = 0, sum = 0, sum2 = 0, max = 0;
  void Add(double x) {
    n += 1;
    sum += x;
    sum2 += x * x;
    max = std::max(max, std::fabs(x));
  }
  double Rms() const { return n > 0 ? std::sqrt(sum2 / n) : 0.0; }
  double Mean() const { return n > 0 ? sum / n : 0.0; }
};

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

Status ValidateRunSetup(const RunSetup& s) {
  if (s.vehicle.rotors.size() < 4) return Status::BadInput(s.vehicle_name + ": rotors: at least 4 are needed");
  if (!(s.options.physics_dt_s > 0 && s.options.physics_dt_s <= 0.01)) {
    return Status::BadInput(fmt::format("sim.physics_dt_s: must be in (0, 0.01] (got {})", s.options.physics_dt_s));
  }
  if (!(s.options.log_rate_hz > 0 && s.options.log_rate_hz <= 1.0 / s.options.physics_dt_s)) {
    return Status::BadInput(fmt::format("sim.log_rate_hz: must be in (0, physics rate] (got {})", s.options.log_rate_hz));
  }
  if (s.options.duration_s < 0) return Status::BadInput("--duration: must be >= 0");
  if (!s.mission.resolved) return Status::BadInput(s.mission.file + ": mission is not resolved to NED");
  if (s.options.estimator != "truth" && s.options.estimator != "eskf" && s.options.estimator != "complementary") {
    return Status::BadInput("sim.estimator: must be truth, eskf or complementary (got '" + s.options.estimator + "')");
  }
  auto field = magnetics::EvaluateWmm({s.world.home_lat_deg, s.world.home_lon_deg, s.world.home_alt_m},
                                      s.world.date_decimal_year, s.world.allow_field_extrapolation);
  if (!field.ok()) return field.status().WithContext(s.world_name);
  auto mixer = control::Mixer::Create(MixerGeometry(s.vehicle));
  if (!mixer.ok()) return mixer.status().WithContext(s.vehicle_name);
  auto sensors = vehicle::SensorSuite::Create(s.vehicle, s.options.seed);
  if (!sensors.ok()) return sensors.status().WithContext(s.vehicle_name);
  return Status::Ok();
}

RunOutput RunMission(const RunSetup& setup) {
  const auto wall_start = std::chrono::steady_clock::now();
  RunOutput out;
  const vehicle::VehicleParams& vp = setup.vehicle;
  const SimOptions& opt = setup.options;
  const double dt = opt.physics_dt_s;

  // --- Environment -------------------------------------------------------------------------
  const magnetics::EarthField field =
      magnetics::EvaluateWmm({setup.world.home_lat_deg, setup.world.home_lon_deg, setup.world.home_alt_m},
                             setup.world.date_decimal_year, setup.world.allow_field_extrapolation)
          .value();
  const Eigen::Vector3d B_earth_N_uT = field.B_N_uT + setup.world.anomaly_N_uT;
  WindParams wind_params = setup.world.wind;
  if (setup.mission.wind) {
    wind_params.mean_N_mps = setup.mission.wind->mean_N_mps;
    wind_params.turbulence_std_mps = setup.mission.wind->gust_std_mps;
  }
  WindModel wind(wind_params, opt.seed);

  // --- Vehicle -----------------------------------------------------------------------------
  RigidBodyParams body_params = BodyParamsFor(vp, setup.world);
  double payload_kg = setup.mission.payload_kg;
  body_params.mass_kg = vp.mass_kg + payload_kg;
  const double rest_D_m = -RestingHeight_m(body_params);
  BodyState start;
  start.p_N_m = Eigen::Vector3d(0, 0, rest_D_m);
  RigidBodyWorld body(body_params, start, /*ground=*/true);
  vehicle::PowertrainState power = vehicle::InitialPowertrainState(vp);
  vehicle::SensorSuite sensors = vehicle::SensorSuite::Create(vp, opt.seed).value();
  double last_imu_t_s = -1.0;
  const size_t n_rotors = vp.rotors.size();

  // --- Autopilot ---------------------------------------------------------------------------
  control::Mixer mixer = control::Mixer::Create(MixerGeometry(vp)).value();
  const double nominal_V = vp.battery.OpenCircuitVoltage_V(vp.battery.initial_soc);
  double max_rotor_thrust_N = 0.0;
  for (size_t i = 0; i < n_rotors; ++i) {
    max_rotor_thrust_N = std::max(max_rotor_thrust_N, vehicle::ThrustForCommand(vp, i, 1.0, nominal_V));
  }
  control::VehicleModelForControl model{vp.mass_kg, vp.inertia_kgm2, max_rotor_thrust_N * n_rotors};
  control::CascadedController controller(setup.control, model);
  control::SequencerParams seq_params;
  seq_params.ground_D_m = rest_D_m;
  control::MissionSequencer sequencer(setup.mission, seq_params);
  const std::vector<Eigen::Vector3d> path = control::PlannedPath(setup.mission, start.p_N_m, rest_D_m);

  const bool use_truth = opt.estimator == "truth";
  std::unique_ptr<nav::Estimator> estimator;
  if (!use_truth) {
    nav::NavParams np = setup.nav;
    np.estimator = opt.estimator;
    np.earth.B_N_uT = field.B_N_uT;  // the autopilot knows the model field, not the local anomaly
    estimator = nav::MakeEstimator(opt.estimator, np).value();
    nav::NavEstimate init;
    init.p_N_m = start.p_N_m;
    init.healthy = false;  // static alignment on the ground
    estimator->Reset(init);
  }

  std::vector<double> commands(n_rotors, 0.0);
  double control_u = 0.0;
  double measured_bus_V = nominal_V;
  double measured_current_A = 0.0;
  Eigen::Vector3d specific_force_B = Eigen::Vector3d(0, 0, -kGravity_mps2);

  // --- Log ---------------------------------------------------------------------------------
  logs::FlightLog& log = out.log;
  LogColumns col(&log, n_rotors, vp.compasses.size());
  const int log_every = std::max(1, static_cast<int>(std::lround(1.0 / (opt.log_rate_hz * dt))));

  // --- Scores ------------------------------------------------------------------------------
  Stats cross_track, yaw_err, current;
  double energy_J = 0.0, distance_m = 0.0;
  nlohmann::json arrivals = nlohmann::json::array();
  std::optional<double> landed_at_s;
  double mission_time_s = 0.0;
  std::string status = "not_completed", reason;
  Status run_status;

  const double t_end = opt.duration_s > 0 ? opt.duration_s : opt.max_duration_s;
  const int64_t steps = static_cast<int64_t>(std::llround(t_end / dt));
  vehicle::PowertrainOutput pt;
  nav::NavEstimate est;
  control::SequencerOutput seq_out;
  BodyState s = body.State();
  for (int64_t k = 0; k <= steps; ++k) {
    const double t = static_cast<double>(k) * dt;
    s = body.State();

    // Sensors sample the truth of this instant (specific force from the last step).
    vehicle::SensorTruth truth;
    truth.t_s = t;
    truth.p_N_m = s.p_N_m;
    truth.v_N_mps = s.v_N_mps;
    truth.q_NB = s.q_NB;
    truth.w_B_radps = s.w_B_radps;
    truth.specific_force_B_mps2 = specific_force_B;
    truth.B_earth_N_uT = B_earth_N_uT;
    truth.currents = pt.motors.empty() ? magnetics::Currents{vp.avionics_current_A, std::vector<double>(n_rotors, 0.0)}
                                       : pt.Currents();
    const vehicle::SensorReadings& rd = sensors.Step(truth);

    // The autopilot runs on each fresh IMU sample.
    if (rd.gyro_radps.fresh) {
      const double ap_dt = last_imu_t_s < 0 ? dt : rd.gyro_radps.t_s - last_imu_t_s;
      last_imu_t_s = rd.gyro_radps.t_s;
      measured_bus_V = pt.motors.empty() ? nominal_V : pt.bus_V;
      measured_current_A = truth.currents.battery_A;
      control::NavState ns;
      ns.t_s = t;
      if (use_truth) {
        ns.p_N_m = s.p_N_m;
        ns.v_N_mps = s.v_N_mps;
        ns.q_NB = s.q_NB;
        ns.w_B_radps = s.w_B_radps;
        est.t_s = t;
        est.p_N_m = s.p_N_m;
        est.v_N_mps = s.v_N_mps;
        est.q_NB = s.q_NB;
        est.w_B_radps = s.w_B_radps;
      } else {
        estimator->PredictImu({rd.gyro_radps.t_s, rd.gyro_radps.value, rd.accel_mps2.value});
        if (!rd.mag_uT.empty() && rd.mag_uT[0].fresh) {
          Eigen::Vector3d m = rd.mag_uT[0].value;
          if (setup.compensator) m = setup.compensator->Correct(m, {control_u, measured_current_A});
          estimator->FuseMag({rd.mag_uT[0].t_s, m});
        }
        if (rd.gps.fresh) estimator->FuseGps({rd.gps.t_s, rd.gps.p_N_m, rd.gps.v_N_mps});
        if (rd.baro.fresh) estimator->FuseBaro({rd.baro.t_s, rd.baro.alt_m});
        est = estimator->Estimate();
        const Status h = estimator->Health();
        if (!h.ok()) {
          status = "diverged";
          reason = "estimator: " + h.message();
          run_status = Status::Numerical(reason);
          break;
        }
        const bool from_est = !opt.control_on_truth;
        ns.p_N_m = from_est ? est.p_N_m : s.p_N_m;
        ns.v_N_mps = from_est ? est.v_N_mps : s.v_N_mps;
        ns.q_NB = from_est ? est.q_NB : s.q_NB;
        ns.w_B_radps = from_est ? est.w_B_radps : s.w_B_radps;
      }
      seq_out = sequencer.Step(ns, ap_dt);
      if (seq_out.payload_event) {
        const auto& ev = *seq_out.payload_event;
        payload_kg = ev.action == control::PayloadAction::kAttach ? payload_kg + ev.mass_kg
                                                                  : std::max(0.0, payload_kg - ev.mass_kg);
        // Point mass at the attachment point, CG kept at the body origin (parallel-axis inertia).
        const Eigen::Vector3d r = vp.payload.attach_B_m;
        const Eigen::Matrix3d I_payload = payload_kg * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
        body.SetMassProperties(vp.mass_kg + payload_kg, vp.inertia_kgm2 + I_payload);
      }
      if (seq_out.arrival) {
        arrivals.push_back({{"index", seq_out.arrival->waypoint_index},
                            {"arrival_error_m", seq_out.arrival->error_m},
                            {"arrival_time_s", seq_out.arrival->t_s}});
      }
      if (seq_out.setpoint.idle) {
        controller.Reset();
        std::fill(commands.begin(), commands.end(), 0.0);
      } else {
        const control::ControlOutput u = controller.Update(ns, seq_out.setpoint, ap_dt);
        double max_thrust = 0.0;
        for (size_t i = 0; i < n_rotors; ++i) {
          max_thrust = std::max(max_thrust, vehicle::ThrustForCommand(vp, i, 1.0, measured_bus_V));
        }
        const control::MixResult mix = mixer.Mix(u.thrust_N, u.torque_B_Nm, max_thrust);
        const double max_up = opt.motor_slew_up_per_s * ap_dt;
        for (size_t i = 0; i < n_rotors; ++i) {
          const double wanted =
              vehicle::CommandForThrust(vp, i, mix.thrust_N[static_cast<Eigen::Index>(i)], measured_bus_V);
          commands[i] = std::min(wanted, commands[i] + max_up);
        }
      }
      control_u = control::ControlAmount(Eigen::Map<const Eigen::VectorXd>(commands.data(), commands.size()));
    }

    // Log this instant.
    if (opt.write_log && k % log_every == 0) {
      log.AppendRow();
      log.Set(col.t, t);
      for (int i = 0; i < 3; ++i) {
        log.Set(col.pos[i], s.p_N_m[i]);
        log.Set(col.vel[i], s.v_N_mps[i]);
        log.Set(col.est_pos[i], est.p_N_m[i]);
        log.Set(col.est_vel[i], est.v_N_mps[i]);
        log.Set(col.wind[i], wind.current_N_mps()[i]);
      }
      const double qc[4] = {s.q_NB.w(), s.q_NB.x(), s.q_NB.y(), s.q_NB.z()};
      const double eq[4] = {est.q_NB.w(), est.q_NB.x(), est.q_NB.y(), est.q_NB.z()};
      for (int i = 0; i < 4; ++i) {
        log.Set(col.q[i], qc[i]);
        log.Set(col.est_q[i], eq[i]);
      }
      if (rd.gyro_radps.valid) {
        for (int i = 0; i < 3; ++i) {
          log.Set(col.gyro[i], rd.gyro_radps.value[i]);
          log.Set(col.accel[i], rd.accel_mps2.value[i]);
        }
      }
      for (size_t c = 0; c < rd.mag_uT.size() && c < col.mag.size(); ++c) {
        if (!rd.mag_uT[c].valid) continue;
        for (int i = 0; i < 3; ++i) log.Set(col.mag[c][static_cast<size_t>(i)], rd.mag_uT[c].value[i]);
        log.Set(col.mag[c][3], rd.mag_uT[c].t_s);
      }
      if (rd.baro.valid) {
        log.Set(col.baro, rd.baro.alt_m);
        log.Set(col.baro_t, rd.baro.t_s);
      }
      if (rd.gps.valid) {
        for (int i = 0; i < 3; ++i) {
          log.Set(col.gps[i], rd.gps.p_N_m[i]);
          log.Set(col.gps_vel[i], rd.gps.v_N_mps[i]);
        }
        log.Set(col.gps_t, rd.gps.t_s);
      }
      log.Set(col.control_u, control_u);
      log.Set(col.current, truth.currents.battery_A);
      log.Set(col.voltage, pt.motors.empty() ? nominal_V : pt.bus_V);
      log.Set(col.soc, power.soc);
      for (size_t i = 0; i < n_rotors; ++i) {
        log.Set(col.motor_u[i], commands[i]);
        log.Set(col.motor_A[i], pt.motors.empty() ? 0.0 : pt.motors[i].dc_A);
      }
      const double yt = YawDeg(s.q_NB), ye = YawDeg(est.q_NB);
      log.Set(col.yaw_true, yt);
      log.Set(col.yaw_est, ye);
      log.Set(col.mode, static_cast<double>(sequencer.mode()));
      log.Set(col.wp, sequencer.waypoint_index());
      log.Set(col.payload, payload_kg);
    }

    // Scores while airborne on a mission leg.
    const bool airborne = sequencer.mode() == control::FlightMode::kWaypoint ||
                          sequencer.mode() == control::FlightMode::kHold;
    if (airborne && sequencer.active_leg() >= 0) {
      cross_track.Add(control::CrossTrackToLeg(path, sequencer.active_leg(), s.p_N_m));
    }
    if (!use_truth && sequencer.mode() != control::FlightMode::kIdle && !sequencer.landed()) {
      yaw_err.Add(WrapDeg180(YawDeg(est.q_NB) - YawDeg(s.q_NB)));
    }
    if (!landed_at_s && (sequencer.done() || (sequencer.landed() && sequencer.mode() == control::FlightMode::kLanded))) {
      landed_at_s = t;
      mission_time_s = t;
      status = "completed";
    }
    if (opt.duration_s <= 0 && landed_at_s && t >= *landed_at_s + opt.settle_after_landing_s) break;

    // Physics step.
    pt = vehicle::StepPowertrain(vp, commands, dt, &power);
    const vehicle::Wrench rotors = vehicle::RotorWrench(vp, power.omega_radps, s.w_B_radps);
    body.AddForce_B(rotors.force_B_N);
    body.AddTorque_B(rotors.torque_B_Nm);
    const Eigen::Vector3d wind_N = wind.Step(dt);
    const Eigen::Vector3d v_air_B = s.q_NB.conjugate() * (s.v_N_mps - wind_N);
    const auto& d = vp.drag;
    body.AddForce_B(-(d.linear_Nspm.cwiseProduct(v_air_B) + d.quadratic_Ns2pm2.cwiseProduct(v_air_B.cwiseAbs().cwiseProduct(v_air_B))));
    body.AddTorque_B(-(d.rotational_Nmsprad.cwiseProduct(s.w_B_radps) +
                       d.rotational_quad_Nms2prad2.cwiseProduct(s.w_B_radps.cwiseAbs().cwiseProduct(s.w_B_radps))));
    body.Step(dt);
    const BodyState next = body.State();
    if (!Finite(next)) {
      status = "diverged";
      reason = fmt::format("non-finite {} at t = {:.3f} s", NonFiniteQuantity(next), t + dt);
      run_status = Status::Numerical(reason);
      break;
    }
    if (next.p_N_m.norm() > 1e5 || next.v_N_mps.norm() > 500.0) {
      status = "diverged";
      reason = fmt::format("{} out of bounds at t = {:.3f} s", next.v_N_mps.norm() > 500.0 ? "velocity" : "position", t + dt);
      run_status = Status::Numerical(reason);
      break;
    }
    // Specific force: what an accelerometer at the CG measures, f = a − g (includes ground contact).
    const Eigen::Vector3d a_N = (next.v_N_mps - s.v_N_mps) / dt;
    specific_force_B = next.q_NB.conjugate() * (a_N - Eigen::Vector3d(0, 0, kGravity_mps2));
    energy_J += pt.power_in_W * dt;
    current.Add(pt.battery_A);
    distance_m += (next.p_N_m - s.p_N_m).norm();
  }

  if (status == "not_completed" && reason.empty()) {
    reason = opt.duration_s > 0 ? fmt::format("duration {} s reached before the mission ended", opt.duration_s)
                                : fmt::format("mission not finished within {} s", opt.max_duration_s);
  }
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  nlohmann::json& sum = out.summary;
  sum["schema"] = "hexsim.summary/1";
  sum["status"] = status;
  sum["reason"] = reason;
  sum["mission"] = setup.mission_name;
  sum["vehicle"] = setup.vehicle_name;
  sum["world"] = setup.world_name;
  sum["calibration"] = setup.calibration_name;
  sum["estimator"] = opt.estimator;
  sum["seed"] = opt.seed;
  sum["duration_s"] = log.rows() > 0 ? log.Column(col.t).back() : 0.0;
  sum["distance_m"] = distance_m;
  sum["cross_track_m"] = {{"max", cross_track.max}, {"rms", cross_track.Rms()}};
  sum["yaw_error_deg"] = {{"max", yaw_err.max}, {"rms", yaw_err.Rms()}};
  sum["energy_Wh"] = energy_J / 3600.0;
  sum["current_A"] = {{"max", current.max}, {"mean", current.Mean()}};
  sum["mission_time_s"] = landed_at_s ? nlohmann::json(mission_time_s) : nlohmann::json(nullptr);
  sum["waypoints"] = arrivals;
  sum["wall_s"] = wall_s;
  sum["version"] = Version();

  log.meta["schema"] = "hexsim.flightlog_meta/1";
  log.meta["source"] = "hexsim";
  log.meta["version"] = Version();
  log.meta["mission"] = setup.mission_name;
  log.meta["vehicle"] = setup.vehicle_name;
  log.meta["world"] = setup.world_name;
  log.meta["calibration"] = setup.calibration_name;
  log.meta["estimator"] = opt.estimator;
  log.meta["seed"] = opt.seed;
  log.meta["log_rate_hz"] = 1.0 / (log_every * dt);
  log.meta["physics_dt_s"] = dt;
  log.meta["location"] = {{"lat_deg", setup.world.home_lat_deg},
                          {"lon_deg", setup.world.home_lon_deg},
                          {"alt_m", setup.world.home_alt_m}};
  log.meta["date_decimal_year"] = setup.world.date_decimal_year;
  log.meta["field_model"] = field.model;
  log.meta["earth_field_N_uT"] = {field.B_N_uT.x(), field.B_N_uT.y(), field.B_N_uT.z()};
  log.meta["declination_deg"] = field.declination_deg;
  log.meta["inclination_deg"] = field.inclination_deg;
  nlohmann::json compasses = nlohmann::json::array();
  for (size_t c = 0; c < vp.compasses.size(); ++c) {
    const auto& cp = vp.compasses[c];
    compasses.push_back({{"column", c == 0 ? "mag" : fmt::format("mag{}", c + 1)},
                         {"name", cp.name},
                         {"external", cp.external},
                         {"position_B_m", {cp.position_B_m.x(), cp.position_B_m.y(), cp.position_B_m.z()}}});
  }
  log.meta["compasses"] = compasses;
  log.meta["rotors"] = n_rotors;
  out.status = run_status;
  return out;
}

}  // namespace hexsim::sim
