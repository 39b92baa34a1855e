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

// WrapPi / WrapDeg180 (common/rotation) bit for bit: inside the principal range fmod is exact and
// returns its argument, so only values outside it take the fmod.
double WrapPiFast(double a) {
  const double x = a + kPi;
  return x > 0.0 && x < 2.0 * kPi ? x - kPi : WrapPi(a);
}
double WrapDeg180Fast(double a) {
  const double x = a + 180.0;
  return x > 0.0 && x < 360.0 ? x - 180.0 : WrapDeg180(a);
}

// YawDeg(q) bit for bit (the same rotation-matrix entries as Eigen's toRotationMatrix, the same
// wraps) without the roll and pitch (asin, atan2) that EulerFromQuat also evaluates: the yaw-error
// statistics take two yaws every step.
double YawDegFast(const Eigen::Quaterniond& q_in) {
  const Eigen::Quaterniond q = q_in.normalized();
  const double ty = 2.0 * q.y(), tz = 2.0 * q.z();
  const double r10 = ty * q.x() + tz * q.w();
  const double r00 = 1.0 - (ty * q.y() + tz * q.z());
  return WrapDeg180Fast(WrapPiFast(std::atan2(r10, r00)) * kRadToDeg);
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

struct Simulation::Impl {
  explicit Impl(const RunSetup& s) : setup(s) {}

  RunSetup setup;
  std::chrono::steady_clock::time_point wall_start = std::chrono::steady_clock::now();
  RunOutput out;
  double dt = 0.001;

  // Environment.
  magnetics::EarthField field;
  Eigen::Vector3d B_earth_N_uT = Eigen::Vector3d::Zero();
  std::optional<WindModel> wind;
  Eigen::Vector3d external_force_N_N = Eigen::Vector3d::Zero();

  // Vehicle.
  RigidBodyParams body_params;
  double payload_kg = 0.0;
  double rest_D_m = 0.0;
  BodyState start;
  std::unique_ptr<RigidBodyWorld> body;
  vehicle::PowertrainState power;
  std::optional<vehicle::SensorSuite> sensors;
  double last_imu_t_s = -1.0;
  // Compass, GPS and baro samples arrive on their own clocks, usually between IMU ticks: each fresh
  // one is held here and fused at the next tick, after the IMU prediction.
  bool pending_mag = false, pending_gps = false, pending_baro = false;
  size_t n_rotors = 0;

  // Autopilot.
  std::optional<control::Mixer> mixer;
  double nominal_V = 0.0;
  control::VehicleModelForControl model;
  std::unique_ptr<control::Controller> controller;
  control::CascadedController* builtin = nullptr;
  std::optional<control::MissionSequencer> sequencer;
  std::vector<Eigen::Vector3d> path;
  std::unique_ptr<nav::Estimator> estimator;  // null: truth
  std::string estimator_name;
  std::shared_ptr<const magnetics::Compensator> compensator;
  SetpointHook setpoint_hook;
  OutputHook output_hook;

  std::vector<double> commands;
  control::MixResult mix;  // kept across steps: its storage is reused
  double control_u = 0.0;
  double measured_bus_V = 0.0;
  double measured_current_A = 0.0;
  Eigen::Vector3d specific_force_B = Eigen::Vector3d(0, 0, -kGravity_mps2);

  // Log.
  std::optional<LogColumns> col;
  int log_every = 1;

  // Scores.
  Stats cross_track, yaw_err, yaw_err_all, current;
  double energy_J = 0.0, distance_m = 0.0;
  nlohmann::json arrivals = nlohmann::json::array();
  std::optional<double> landed_at_s;
  double mission_time_s = 0.0;
  std::string status = "not_completed", reason;
  Status run_status;

  // Loop state.
  int64_t steps = 0;
  int64_t k = 0;
  bool finished = false;
  bool finalised = false;
  vehicle::PowertrainOutput pt;
  nav::NavEstimate est;
  control::SequencerOutput seq_out;
  control::NavState ns;
  control::ControlOutput u;
  vehicle::SensorTruth truth;
  const vehicle::SensorReadings* rd = nullptr;
  vehicle::SensorReadings empty_readings;
  BodyState s;

  void Build();
  void ResetEstimator();
  void ApplyPayload();
  bool Step();
  RunOutput Finish();
};

void Simulation::Impl::Build() {
  const vehicle::VehicleParams& vp = setup.vehicle;
  const SimOptions& opt = setup.options;
  dt = opt.physics_dt_s;

  // --- Environment -------------------------------------------------------------------------
  field = magnetics::EvaluateWmm({setup.world.home_lat_deg, setup.world.home_lon_deg, setup.world.home_alt_m},
                                 setup.world.date_decimal_year, setup.world.allow_field_extrapolation)
              .value();
  B_earth_N_uT = field.B_N_uT + setup.world.anomaly_N_uT;
  WindParams wind_params = setup.world.wind;
  if (setup.mission.wind) {
    wind_params.mean_N_mps = setup.mission.wind->mean_N_mps;
    wind_params.turbulence_std_mps = setup.mission.wind->gust_std_mps;
  }
  wind.emplace(wind_params, opt.seed);

  // --- Vehicle -----------------------------------------------------------------------------
  body_params = BodyParamsFor(vp, setup.world);
  payload_kg = setup.mission.payload_kg;
  body_params.mass_kg = vp.mass_kg + payload_kg;
  rest_D_m = -RestingHeight_m(body_params);
  start.p_N_m = Eigen::Vector3d(0, 0, rest_D_m);
  body = std::make_unique<RigidBodyWorld>(body_params, start, /*ground=*/true);
  power = vehicle::InitialPowertrainState(vp);
  sensors.emplace(vehicle::SensorSuite::Create(vp, opt.seed).value());
  n_rotors = vp.rotors.size();

  // --- Autopilot ---------------------------------------------------------------------------
  mixer.emplace(control::Mixer::Create(MixerGeometry(vp)).value());
  nominal_V = vp.battery.OpenCircuitVoltage_V(vp.battery.initial_soc);
  double max_rotor_thrust_N = 0.0;
  for (size_t i = 0; i < n_rotors; ++i) {
    max_rotor_thrust_N = std::max(max_rotor_thrust_N, vehicle::ThrustForCommand(vp, i, 1.0, nominal_V));
  }
  model = control::VehicleModelForControl{vp.mass_kg, vp.inertia_kgm2, max_rotor_thrust_N * n_rotors};
  auto cascade = std::make_unique<control::CascadedController>(setup.control, model);
  builtin = cascade.get();
  controller = std::move(cascade);
  control::SequencerParams seq_params;
  seq_params.ground_D_m = rest_D_m;
  sequencer.emplace(setup.mission, seq_params);
  path = control::PlannedPath(setup.mission, start.p_N_m, rest_D_m);

  estimator_name = opt.estimator;
  compensator = setup.compensator;
  if (opt.estimator != "truth") {
    nav::NavParams np = setup.nav;
    np.estimator = opt.estimator;
    np.earth.B_N_uT = field.B_N_uT;  // the autopilot knows the model field, not the local anomaly
    estimator = nav::MakeEstimator(opt.estimator, np).value();
    ResetEstimator();
  }

  commands.assign(n_rotors, 0.0);
  measured_bus_V = nominal_V;
  truth.currents.battery_A = vp.avionics_current_A;
  truth.currents.motor_A.assign(n_rotors, 0.0);
  pt.motors.reserve(n_rotors);

  // --- Log ---------------------------------------------------------------------------------
  col.emplace(&out.log, n_rotors, vp.compasses.size());
  log_every = std::max(1, static_cast<int>(std::lround(1.0 / (opt.log_rate_hz * dt))));

  const double t_end = opt.duration_s > 0 ? opt.duration_s : opt.max_duration_s;
  steps = static_cast<int64_t>(std::llround(t_end / dt));
  // A fixed duration fixes the row count (steps + 1 instants, every log_every-th logged): reserve
  // it so the columns never grow. An open-ended mission is left to grow.
  if (opt.write_log && opt.duration_s > 0) out.log.Reserve(static_cast<size_t>(steps / log_every + 1));
  s = body->State();
  empty_readings.mag_uT.resize(vp.compasses.size());
  rd = &empty_readings;
}

void Simulation::Impl::ResetEstimator() {
  nav::NavEstimate init;
  init.p_N_m = body ? body->State().p_N_m : start.p_N_m;
  init.healthy = false;  // static alignment on the ground
  estimator->Reset(init);
}

void Simulation::Impl::ApplyPayload() {
  const vehicle::VehicleParams& vp = setup.vehicle;
  // Point mass at the attachment point, CG kept at the body origin (parallel-axis inertia).
  const Eigen::Vector3d r = vp.payload.attach_B_m;
  const Eigen::Matrix3d I_payload = payload_kg * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
  body->SetMassProperties(vp.mass_kg + payload_kg, vp.inertia_kgm2 + I_payload);
}

bool Simulation::Impl::Step() {
  if (finished) return false;
  if (k > steps) {
    finished = true;
    return false;
  }
  const vehicle::VehicleParams& vp = setup.vehicle;
  const SimOptions& opt = setup.options;
  logs::FlightLog& log = out.log;
  const bool use_truth = estimator == nullptr;
  const double t = static_cast<double>(k) * dt;
  // `s` is the body's state at t: read in Build and after every physics step (below); nothing in
  // between moves the body (payload changes keep the state).

  // Sensors sample the truth of this instant (specific force from the last step).
  truth.t_s = t;
  truth.p_N_m = s.p_N_m;
  truth.v_N_mps = s.v_N_mps;
  truth.q_NB = s.q_NB;
  truth.w_B_radps = s.w_B_radps;
  truth.specific_force_B_mps2 = specific_force_B;
  truth.B_earth_N_uT = B_earth_N_uT;
  if (pt.motors.empty()) {
    truth.currents.battery_A = vp.avionics_current_A;
    std::fill(truth.currents.motor_A.begin(), truth.currents.motor_A.end(), 0.0);
  } else {
    truth.currents.battery_A = pt.battery_A;
    for (size_t i = 0; i < n_rotors; ++i) truth.currents.motor_A[i] = pt.motors[i].dc_A;
  }
  rd = &sensors->Step(truth);

  pending_mag = pending_mag || (!rd->mag_uT.empty() && rd->mag_uT[0].fresh);
  pending_gps = pending_gps || rd->gps.fresh;
  pending_baro = pending_baro || rd->baro.fresh;

  // The autopilot runs on each fresh IMU sample.
  if (rd->gyro_radps.fresh) {
    const double ap_dt = last_imu_t_s < 0 ? dt : rd->gyro_radps.t_s - last_imu_t_s;
    last_imu_t_s = rd->gyro_radps.t_s;
    measured_bus_V = pt.motors.empty() ? nominal_V : pt.bus_V;
    measured_current_A = truth.currents.battery_A;
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
      estimator->PredictImu({rd->gyro_radps.t_s, rd->gyro_radps.value, rd->accel_mps2.value});
      // The readings hold their latest sample, so a pending one is still in `rd`.
      if (pending_mag) {
        Eigen::Vector3d m = rd->mag_uT[0].value;
        if (compensator) m = compensator->Correct(m, {control_u, measured_current_A});
        estimator->FuseMag({rd->mag_uT[0].t_s, m});
      }
      if (pending_gps) estimator->FuseGps({rd->gps.t_s, rd->gps.p_N_m, rd->gps.v_N_mps});
      if (pending_baro) estimator->FuseBaro({rd->baro.t_s, rd->baro.alt_m});
      pending_mag = pending_gps = pending_baro = false;
      est = estimator->Estimate();
      const Status h = estimator->Health();
      if (!h.ok()) {
        status = "diverged";
        reason = "estimator: " + h.message();
        run_status = Status::Numerical(reason);
        finished = true;
        return false;
      }
      const bool from_est = !opt.control_on_truth;
      ns.p_N_m = from_est ? est.p_N_m : s.p_N_m;
      ns.v_N_mps = from_est ? est.v_N_mps : s.v_N_mps;
      ns.q_NB = from_est ? est.q_NB : s.q_NB;
      ns.w_B_radps = from_est ? est.w_B_radps : s.w_B_radps;
    }
    // The mission starts once the estimator has aligned on the ground (as an autopilot refuses to
    // arm before its EKF is healthy); until then the motors stay off.
    const bool armed = use_truth || opt.control_on_truth || est.healthy || !sequencer->landed();
    if (armed) {
      seq_out = sequencer->Step(ns, ap_dt);
    } else {
      seq_out = control::SequencerOutput{};
      seq_out.setpoint.idle = true;
    }
    if (seq_out.payload_event) {
      const auto& ev = *seq_out.payload_event;
      payload_kg = ev.action == control::PayloadAction::kAttach ? payload_kg + ev.mass_kg
                                                                : std::max(0.0, payload_kg - ev.mass_kg);
      ApplyPayload();
    }
    if (seq_out.arrival) {
      arrivals.push_back({{"index", seq_out.arrival->waypoint_index},
                          {"arrival_error_m", seq_out.arrival->error_m},
                          {"arrival_time_s", seq_out.arrival->t_s}});
    }
    if (setpoint_hook) setpoint_hook(t, ns, &seq_out.setpoint);
    if (seq_out.setpoint.idle) {
      controller->Reset();
      std::fill(commands.begin(), commands.end(), 0.0);
      u = control::ControlOutput{};
    } else {
      u = controller->Update(ns, seq_out.setpoint, ap_dt);
      if (output_hook) output_hook(t, ns, &u);
      double max_thrust = 0.0;
      for (size_t i = 0; i < n_rotors; ++i) {
        max_thrust = std::max(max_thrust, vehicle::ThrustForCommand(vp, i, 1.0, measured_bus_V));
      }
      mixer->Mix(u.thrust_N, u.torque_B_Nm, max_thrust, &mix);
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
    const LogColumns& c = *col;
    log.AppendRow();
    log.Set(c.t, t);
    for (int i = 0; i < 3; ++i) {
      log.Set(c.pos[i], s.p_N_m[i]);
      log.Set(c.vel[i], s.v_N_mps[i]);
      log.Set(c.est_pos[i], est.p_N_m[i]);
      log.Set(c.est_vel[i], est.v_N_mps[i]);
      log.Set(c.wind[i], wind->current_N_mps()[i]);
    }
    const double qc[4] = {s.q_NB.w(), s.q_NB.x(), s.q_NB.y(), s.q_NB.z()};
    const double eq[4] = {est.q_NB.w(), est.q_NB.x(), est.q_NB.y(), est.q_NB.z()};
    for (int i = 0; i < 4; ++i) {
      log.Set(c.q[i], qc[i]);
      log.Set(c.est_q[i], eq[i]);
    }
    if (rd->gyro_radps.valid) {
      for (int i = 0; i < 3; ++i) {
        log.Set(c.gyro[i], rd->gyro_radps.value[i]);
        log.Set(c.accel[i], rd->accel_mps2.value[i]);
      }
    }
    for (size_t m = 0; m < rd->mag_uT.size() && m < c.mag.size(); ++m) {
      if (!rd->mag_uT[m].valid) continue;
      for (int i = 0; i < 3; ++i) log.Set(c.mag[m][static_cast<size_t>(i)], rd->mag_uT[m].value[i]);
      log.Set(c.mag[m][3], rd->mag_uT[m].t_s);
    }
    if (rd->baro.valid) {
      log.Set(c.baro, rd->baro.alt_m);
      log.Set(c.baro_t, rd->baro.t_s);
    }
    if (rd->gps.valid) {
      for (int i = 0; i < 3; ++i) {
        log.Set(c.gps[i], rd->gps.p_N_m[i]);
        log.Set(c.gps_vel[i], rd->gps.v_N_mps[i]);
      }
      log.Set(c.gps_t, rd->gps.t_s);
    }
    log.Set(c.control_u, control_u);
    log.Set(c.current, truth.currents.battery_A);
    log.Set(c.voltage, pt.motors.empty() ? nominal_V : pt.bus_V);
    log.Set(c.soc, power.soc);
    for (size_t i = 0; i < n_rotors; ++i) {
      log.Set(c.motor_u[i], commands[i]);
      log.Set(c.motor_A[i], pt.motors.empty() ? 0.0 : pt.motors[i].dc_A);
    }
    log.Set(c.yaw_true, YawDegFast(s.q_NB));
    log.Set(c.yaw_est, YawDegFast(est.q_NB));
    log.Set(c.mode, static_cast<double>(sequencer->mode()));
    log.Set(c.wp, sequencer->waypoint_index());
    log.Set(c.payload, payload_kg);
  }

  // Scores while airborne on a mission leg.
  const bool airborne = sequencer->mode() == control::FlightMode::kWaypoint ||
                        sequencer->mode() == control::FlightMode::kHold;
  if (airborne && sequencer->active_leg() >= 0) {
    cross_track.Add(control::CrossTrackToLeg(path, sequencer->active_leg(), s.p_N_m));
  }
  // Yaw error is scored like cross-track, on the mission legs (the paper's in-flight figure);
  // yaw_error_all_deg also covers take-off and landing, where the rotor spin-up transient lives.
  if (!use_truth && sequencer->mode() != control::FlightMode::kIdle && !sequencer->landed()) {
    const double e = WrapDeg180Fast(YawDegFast(est.q_NB) - YawDegFast(s.q_NB));
    yaw_err_all.Add(e);
    if (airborne) yaw_err.Add(e);
  }
  if (!landed_at_s &&
      (sequencer->done() || (sequencer->landed() && sequencer->mode() == control::FlightMode::kLanded))) {
    landed_at_s = t;
    mission_time_s = t;
    status = "completed";
  }
  if (opt.duration_s <= 0 && landed_at_s && t >= *landed_at_s + opt.settle_after_landing_s) {
    finished = true;
    return false;
  }

  // Physics step.
  vehicle::StepPowertrain(vp, commands, dt, &power, &pt);
  const vehicle::Wrench rotors = vehicle::RotorWrench(vp, power.omega_radps, s.w_B_radps);
  body->AddForce_B(rotors.force_B_N);
  body->AddTorque_B(rotors.torque_B_Nm);
  const Eigen::Vector3d wind_N = wind->Step(dt);
  const Eigen::Vector3d v_air_B = s.q_NB.conjugate() * (s.v_N_mps - wind_N);
  const auto& d = vp.drag;
  body->AddForce_B(-(d.linear_Nspm.cwiseProduct(v_air_B) +
                     d.quadratic_Ns2pm2.cwiseProduct(v_air_B.cwiseAbs().cwiseProduct(v_air_B))));
  body->AddTorque_B(-(d.rotational_Nmsprad.cwiseProduct(s.w_B_radps) +
                      d.rotational_quad_Nms2prad2.cwiseProduct(s.w_B_radps.cwiseAbs().cwiseProduct(s.w_B_radps))));
  // Optional rotor aerodynamics (vehicle `aero:`; 0 = off, and then nothing is added).
  const vehicle::AeroParams& aero = vp.aero;
  if (aero.rotor_drag_N_per_radps_mps > 0.0) {
    double omega_sum = 0.0;
    for (double w : power.omega_radps) omega_sum += w;
    // F_B = −k·(Σω)·(v_x, v_y, 0): induced drag / blade flapping, in the rotor plane.
    body->AddForce_B(-aero.rotor_drag_N_per_radps_mps * omega_sum * Eigen::Vector3d(v_air_B.x(), v_air_B.y(), 0.0));
  }
  if (aero.ground_effect_radius_m > 0.0) {
    // T_IGE/T_OGE = 1/(1 − (R/4z)²) per rotor, z the hub height above the ground plane D = 0.
    const double R = aero.ground_effect_radius_m;
    for (size_t i = 0; i < vp.rotors.size(); ++i) {
      const auto& rp = vp.rotors[i];
      const double hub_D_m = s.p_N_m.z() + (s.q_NB * rp.position_B_m).z();
      const double z_m = std::max(0.5 * R, -hub_D_m);
      const double x = R / (4.0 * z_m);
      const double extra = 1.0 / (1.0 - x * x) - 1.0;
      const Eigen::Vector3d dF_B =
          extra * rp.k_T_Nprps2 * power.omega_radps[i] * power.omega_radps[i] * rp.axis_B;
      body->AddForce_B(dF_B);
      body->AddTorque_B(rp.position_B_m.cross(dF_B));
    }
  }
  if (!external_force_N_N.isZero()) body->AddForce_N(external_force_N_N);
  body->Step(dt);
  const BodyState next = body->State();
  if (!Finite(next)) {
    status = "diverged";
    reason = fmt::format("non-finite {} at t = {:.3f} s", NonFiniteQuantity(next), t + dt);
    run_status = Status::Numerical(reason);
    finished = true;
    return false;
  }
  if (next.p_N_m.norm() > 1e5 || next.v_N_mps.norm() > 500.0) {
    status = "diverged";
    reason = fmt::format("{} out of bounds at t = {:.3f} s", next.v_N_mps.norm() > 500.0 ? "velocity" : "position",
                         t + dt);
    run_status = Status::Numerical(reason);
    finished = true;
    return false;
  }
  // Specific force: what an accelerometer at the CG measures, f = a − g (includes ground contact).
  const Eigen::Vector3d a_N = (next.v_N_mps - s.v_N_mps) / dt;
  specific_force_B = next.q_NB.conjugate() * (a_N - Eigen::Vector3d(0, 0, kGravity_mps2));
  energy_J += pt.power_in_W * dt;
  current.Add(pt.battery_A);
  distance_m += (next.p_N_m - s.p_N_m).norm();
  s = next;
  ++k;
  return true;
}

RunOutput Simulation::Impl::Finish() {
  finished = true;
  finalised = true;
  const vehicle::VehicleParams& vp = setup.vehicle;
  const SimOptions& opt = setup.options;
  logs::FlightLog& log = out.log;
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
  sum["estimator"] = estimator_name;
  sum["seed"] = opt.seed;
  sum["duration_s"] = log.rows() > 0 ? log.Column(col->t).back() : 0.0;
  sum["distance_m"] = distance_m;
  sum["cross_track_m"] = {{"max", cross_track.max}, {"rms", cross_track.Rms()}};
  sum["yaw_error_deg"] = {{"max", yaw_err.max}, {"rms", yaw_err.Rms()}};
  sum["yaw_error_all_deg"] = {{"max", yaw_err_all.max}, {"rms", yaw_err_all.Rms()}};
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
  log.meta["estimator"] = estimator_name;
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
  return std::move(out);
}

// --- Simulation ----------------------------------------------------------------------------------

Simulation::Simulation(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Simulation::~Simulation() = default;

Result<std::unique_ptr<Simulation>> Simulation::Create(const RunSetup& setup) {
  HEXSIM_RETURN_IF_ERROR(ValidateRunSetup(setup));
  auto impl = std::make_unique<Impl>(setup);
  impl->Build();
  return std::unique_ptr<Simulation>(new Simulation(std::move(impl)));
}

void Simulation::SetController(std::unique_ptr<control::Controller> controller) {
  if (controller) {
    impl_->controller = std::move(controller);
    impl_->builtin = nullptr;
  } else {
    auto cascade = std::make_unique<control::CascadedController>(impl_->setup.control, impl_->model);
    impl_->builtin = cascade.get();
    impl_->controller = std::move(cascade);
  }
}

void Simulation::SetEstimator(std::unique_ptr<nav::Estimator> estimator) {
  impl_->estimator = std::move(estimator);
  if (impl_->estimator) {
    impl_->estimator_name = impl_->estimator->name();
    impl_->ResetEstimator();
  } else {
    impl_->estimator_name = "truth";
  }
}

void Simulation::SetCompensator(std::shared_ptr<const magnetics::Compensator> compensator) {
  impl_->compensator = std::move(compensator);
}
void Simulation::SetSetpointHook(SetpointHook hook) { impl_->setpoint_hook = std::move(hook); }
void Simulation::SetOutputHook(OutputHook hook) { impl_->output_hook = std::move(hook); }

void Simulation::SetWindMean(const Eigen::Vector3d& wind_N_mps) { impl_->wind->SetMean(wind_N_mps); }
void Simulation::ChangePayload(double delta_kg) {
  impl_->payload_kg = std::max(0.0, impl_->payload_kg + delta_kg);
  impl_->ApplyPayload();
}
void Simulation::SetExternalForce(const Eigen::Vector3d& force_N_N) { impl_->external_force_N_N = force_N_N; }

bool Simulation::Step() { return impl_->Step(); }
void Simulation::RunToEnd() {
  while (impl_->Step()) {
  }
}
RunOutput Simulation::Finish() {
  if (impl_->finalised) return RunOutput{};
  return impl_->Finish();
}

double Simulation::time_s() const { return static_cast<double>(impl_->k) * impl_->dt; }
bool Simulation::finished() const { return impl_->finished; }
const BodyState& Simulation::true_state() const { return impl_->s; }
const vehicle::SensorReadings& Simulation::sensors() const { return *impl_->rd; }
const nav::NavEstimate& Simulation::estimate() const { return impl_->est; }
const control::NavState& Simulation::nav_state() const { return impl_->ns; }
const control::Setpoint& Simulation::setpoint() const { return impl_->seq_out.setpoint; }
const control::ControlOutput& Simulation::control_output() const { return impl_->u; }
const magnetics::Currents& Simulation::currents() const { return impl_->truth.currents; }
const std::vector<double>& Simulation::motor_commands() const { return impl_->commands; }
double Simulation::payload_kg() const { return impl_->payload_kg; }
const control::VehicleModelForControl& Simulation::control_model() const { return impl_->model; }
const RunSetup& Simulation::setup() const { return impl_->setup; }
const control::CascadedController* Simulation::builtin_controller() const { return impl_->builtin; }

RunOutput RunMission(const RunSetup& setup) {
  auto sim = Simulation::Create(setup);
  if (!sim.ok()) {
    RunOutput out;
    out.status = sim.status();
    // Invalid setup (callers normally validate first): nothing was flown; out.status says why.
    out.summary = {{"schema", "hexsim.summary/1"}, {"status", "not_completed"}, {"reason", sim.status().message()}};
    return out;
  }
  (*sim)->RunToEnd();
  return (*sim)->Finish();
}

}  // namespace hexsim::sim
