// The closed loop: the stages (sensors → autopilot → physics, stages.h) called in order each
// physics step, the observers (LogRecorder, RunScorer, step_record.h) fed a StepRecord in between,
// and the run's end (mission landed and settled, duration reached, divergence) and summary.
#include "hexsim/sim/simulation.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>

#include <fmt/format.h>

#include "hexsim/common/paths.h"
#include "hexsim/magnetics/wmm.h"
#include "stages.h"
#include "hexsim/sim/step_record.h"

namespace hexsim::sim {

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
  Impl(const RunSetup& s, Plugins plugins)
      : setup(s),
        field(magnetics::EvaluateWmm({setup.world.home_lat_deg, setup.world.home_lon_deg, setup.world.home_alt_m},
                                     setup.world.date_decimal_year, setup.world.allow_field_extrapolation)
                  .value()),
        dt(setup.options.physics_dt_s),
        physics(setup, setup.options.seed),
        sensors(setup.vehicle, setup.options.seed, field.B_N_uT + setup.world.anomaly_N_uT),
        autopilot(setup, std::move(plugins), field, physics.rest_D_m(), physics.start().p_N_m),
        nominal_V(setup.vehicle.battery.OpenCircuitVoltage_V(setup.vehicle.battery.initial_soc)),
        log_every(std::max(1, static_cast<int>(std::lround(1.0 / (setup.options.log_rate_hz * dt))))),
        recorder(&out.log, setup.vehicle.rotors.size(), setup.vehicle.compasses.size(), log_every),
        scorer(autopilot.path()) {
    const SimOptions& opt = setup.options;
    const double t_end = opt.duration_s > 0 ? opt.duration_s : opt.max_duration_s;
    steps = static_cast<int64_t>(std::llround(t_end / dt));
    // A fixed duration fixes the row count (steps + 1 instants, every log_every-th logged): reserve
    // it so the columns never grow. An open-ended mission is left to grow.
    if (opt.write_log && opt.duration_s > 0) out.log.Reserve(static_cast<size_t>(steps / log_every + 1));
    if (opt.write_log && opt.stream_rate_hz > 0) recorder.EnableStreams(opt.stream_rate_hz);
  }

  RunSetup setup;
  std::chrono::steady_clock::time_point wall_start = std::chrono::steady_clock::now();
  RunOutput out;
  magnetics::EarthField field;
  double dt;

  // The stages, in the order a step calls them (physics first here: the others start from its
  // initial state).
  PhysicsStage physics;
  SensorStage sensors;
  Autopilot autopilot;
  double nominal_V;

  // The observers.
  int log_every;
  LogRecorder recorder;
  RunScorer scorer;

  // The run's end.
  std::optional<double> landed_at_s;
  double mission_time_s = 0.0;
  std::string status = "not_completed", reason;
  Status run_status;
  int64_t steps = 0;
  int64_t k = 0;
  bool finished = false;
  bool finalised = false;

  bool Step();
  bool Diverged(const std::string& why);
  RunOutput Finish();
};

bool Simulation::Impl::Diverged(const std::string& why) {
  status = "diverged";
  reason = why;
  run_status = Status::Numerical(reason);
  finished = true;
  return false;
}

bool Simulation::Impl::Step() {
  if (finished) return false;
  if (k > steps) {
    finished = true;
    return false;
  }
  const SimOptions& opt = setup.options;
  const double t = static_cast<double>(k) * dt;
  const BodyState& s = physics.state();
  const vehicle::PowertrainOutput& pt = physics.powertrain();

  // 1. Sensors sample the truth of this instant (specific force and currents from the last step).
  const vehicle::SensorReadings& rd = sensors.Sample(t, s, physics.specific_force_B_mps2(), pt);
  const double battery_A = sensors.currents().battery_A;

  // 2. The autopilot runs on each fresh IMU sample.
  const Autopilot::Tick tick = autopilot.Step(t, dt, rd, s, pt.motors.empty() ? nominal_V : pt.bus_V, battery_A);
  if (!tick.failure.empty()) return Diverged(tick.failure);
  if (tick.payload_event) {
    const auto& ev = *tick.payload_event;
    physics.SetPayload_kg(ev.action == control::PayloadAction::kAttach ? physics.payload_kg() + ev.mass_kg
                                                                       : std::max(0.0, physics.payload_kg() - ev.mass_kg));
  }

  // 3. The observers read this instant.
  const control::MissionSequencer& seq = autopilot.sequencer();
  StepRecord r;
  r.step = k;
  r.t_s = t;
  r.truth = &s;
  r.readings = &rd;
  r.estimate = &autopilot.estimate();
  r.estimated = autopilot.estimated();
  r.commands = &autopilot.commands();
  r.control_u = autopilot.control_u();
  r.powertrain = &pt;
  r.battery_A = battery_A;
  r.soc = physics.soc();
  r.nominal_V = nominal_V;
  r.wind_N_mps = physics.wind_N_mps();
  r.mode = seq.mode();
  r.waypoint_index = seq.waypoint_index();
  r.active_leg = seq.active_leg();
  r.landed = seq.landed();
  r.payload_kg = physics.payload_kg();
  r.arrival = tick.arrival;
  if (opt.write_log) recorder.OnStep(r);
  scorer.OnStep(r);
  if (!landed_at_s && (seq.done() || (seq.landed() && seq.mode() == control::FlightMode::kLanded))) {
    landed_at_s = t;
    mission_time_s = t;
    status = "completed";
  }
  if (opt.duration_s <= 0 && opt.end_when_landed && landed_at_s && t >= *landed_at_s + opt.settle_after_landing_s) {
    finished = true;
    return false;
  }

  // 4. Physics advances the body by one step.
  const std::string why = physics.Advance(autopilot.commands(), t, dt);
  if (!why.empty()) return Diverged(why);
  StepInterval iv;
  iv.t_s = t;
  iv.dt_s = dt;
  iv.powertrain = &physics.powertrain();
  iv.p_before_N_m = physics.previous_p_N_m();
  iv.p_after_N_m = physics.state().p_N_m;
  scorer.OnInterval(iv);
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
  RunSummary& sum = out.summary;
  sum.status = status == "completed" ? RunStatus::kCompleted
               : status == "diverged" ? RunStatus::kDiverged
                                      : RunStatus::kNotCompleted;
  sum.reason = reason;
  sum.mission = setup.mission_name;
  sum.vehicle = setup.vehicle_name;
  sum.world = setup.world_name;
  sum.calibration = setup.calibration_name;
  sum.estimator = autopilot.estimator_name();
  sum.seed = opt.seed;
  sum.duration_s = log.rows() > 0 ? log.Column(recorder.time_column()).back() : 0.0;
  scorer.WriteSummary(&sum);
  if (landed_at_s) sum.mission_time_s = mission_time_s;
  sum.wall_s = wall_s;
  sum.version = Version();

  log.meta["schema"] = "hexsim.flightlog_meta/1";
  log.meta["source"] = "hexsim";
  log.meta["version"] = Version();
  log.meta["mission"] = setup.mission_name;
  log.meta["vehicle"] = setup.vehicle_name;
  log.meta["world"] = setup.world_name;
  log.meta["calibration"] = setup.calibration_name;
  log.meta["estimator"] = autopilot.estimator_name();
  // The `mode` column holds control::FlightMode numbers; plots name them.
  for (int m = static_cast<int>(control::FlightMode::kIdle); m <= static_cast<int>(control::FlightMode::kDone); ++m) {
    log.meta["mode_names"][std::to_string(m)] = control::FlightModeName(static_cast<control::FlightMode>(m));
  }
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
  log.meta["rotors"] = vp.rotors.size();
  if (opt.stream_rate_hz > 0) log.meta["stream_rate_hz"] = opt.stream_rate_hz;
  recorder.AttachStreams();
  out.status = run_status;
  return std::move(out);
}

// --- Simulation ----------------------------------------------------------------------------------

Simulation::Simulation(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Simulation::~Simulation() = default;

Result<std::unique_ptr<Simulation>> Simulation::Create(const RunSetup& setup, Plugins plugins) {
  HEXSIM_RETURN_IF_ERROR(ValidateRunSetup(setup));
  return std::unique_ptr<Simulation>(new Simulation(std::make_unique<Impl>(setup, std::move(plugins))));
}

void Simulation::SetWindMean(const Eigen::Vector3d& wind_N_mps) { impl_->physics.SetWindMean(wind_N_mps); }
void Simulation::ChangePayload(double delta_kg) {
  impl_->physics.SetPayload_kg(std::max(0.0, impl_->physics.payload_kg() + delta_kg));
}
void Simulation::SetExternalForce(const Eigen::Vector3d& force_N_N) { impl_->physics.SetExternalForce(force_N_N); }

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
const BodyState& Simulation::true_state() const { return impl_->physics.state(); }
const vehicle::SensorReadings& Simulation::sensors() const { return impl_->sensors.readings(); }
const nav::NavEstimate& Simulation::estimate() const { return impl_->autopilot.estimate(); }
const control::NavState& Simulation::nav_state() const { return impl_->autopilot.nav_state(); }
const control::Setpoint& Simulation::setpoint() const { return impl_->autopilot.setpoint(); }
const control::ControlOutput& Simulation::control_output() const { return impl_->autopilot.control_output(); }
const magnetics::Currents& Simulation::currents() const { return impl_->sensors.currents(); }
const std::vector<double>& Simulation::motor_commands() const { return impl_->autopilot.commands(); }
const vehicle::PowertrainOutput& Simulation::powertrain() const { return impl_->physics.powertrain(); }
const Eigen::Vector3d& Simulation::specific_force_B_mps2() const { return impl_->physics.specific_force_B_mps2(); }
double Simulation::soc() const { return impl_->physics.soc(); }
const logs::FlightLog& Simulation::log() const { return impl_->out.log; }
double Simulation::payload_kg() const { return impl_->physics.payload_kg(); }
const control::VehicleModelForControl& Simulation::control_model() const { return impl_->autopilot.model(); }
const RunSetup& Simulation::setup() const { return impl_->setup; }
const control::CascadedController* Simulation::builtin_controller() const { return impl_->autopilot.builtin(); }

RunOutput RunMission(const RunSetup& setup) {
  auto sim = Simulation::Create(setup);
  if (!sim.ok()) {
    RunOutput out;
    out.status = sim.status();
    // Invalid setup (callers normally validate first): nothing was flown; out.status says why.
    out.summary.status = RunStatus::kNotCompleted;
    out.summary.reason = sim.status().message();
    return out;
  }
  (*sim)->RunToEnd();
  return (*sim)->Finish();
}

}  // namespace hexsim::sim
