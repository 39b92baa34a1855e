#include "hexsim/envs/env.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "hexsim/common/rotation.h"
#include "hexsim/control/mixer.h"
#include "hexsim/sim/mixer_geometry.h"
#include "hexsim/vehicle/powertrain.h"

namespace hexsim::envs {

const std::array<const char*, kInfoSize> kInfoNames = {
    "t_s",          "position_error_m", "battery_A",   "tilt_deg",     "height_m",
    "waypoint_index", "is_success",     "cross_track_m", "yaw_true_deg", "yaw_est_deg",
    "yaw_error_deg", "true_p_N_m",      "true_p_E_m",  "true_p_D_m"};

namespace {

double YawOf(const Eigen::Quaterniond& q) {  // ZYX yaw of q_NB (rad)
  return std::atan2(2.0 * (q.w() * q.z() + q.x() * q.y()), 1.0 - 2.0 * (q.y() * q.y() + q.z() * q.z()));
}

double TiltDeg(const Eigen::Quaterniond& q) {  // angle between body z and NED down
  const double c = 1.0 - 2.0 * (q.x() * q.x() + q.y() * q.y());
  return std::acos(std::clamp(c, -1.0, 1.0)) * kRadToDeg;
}

double* Put(const Eigen::Vector3d& v, double* out) {
  out[0] = v.x();
  out[1] = v.y();
  out[2] = v.z();
  return out + 3;
}

double* Put(const Eigen::Quaterniond& q, double* out) {
  out[0] = q.w();
  out[1] = q.x();
  out[2] = q.y();
  out[3] = q.z();
  return out + 4;
}

double TotalThrustN(const vehicle::VehicleParams& v, double command) {
  const vehicle::PowertrainOutput pt = vehicle::SteadyStateForCommand(v, command, v.battery.initial_soc);
  double sum = 0.0;
  for (size_t i = 0; i < pt.motors.size(); ++i) {
    sum += v.rotors[i].k_T_Nprps2 * pt.motors[i].omega_radps * pt.motors[i].omega_radps;
  }
  return sum;
}

}  // namespace

Status EnvOptions::Validate() const {
  auto bad = [](const std::string& field, const std::string& what) { return Status::BadInput(field + ": " + what); };
  if (act != ActMode::kMotors && act != ActMode::kRates && act != ActMode::kAttitude) {
    return bad("act", "expected motors, rates or attitude");
  }
  if (task == Task::kCompassWaypoint && observe == ObsSource::kTruth) {
    return bad("observe", "CompassWaypoint observes what the autopilot has: sensors or estimator, never truth");
  }
  if (task != Task::kHover && waypoints_N_m.empty()) return bad("waypoints_N_m", "at least one waypoint");
  for (const auto& w : waypoints_N_m) {
    if (!w.allFinite()) return bad("waypoints_N_m", "not a finite number");
  }
  if (!target_N_m.allFinite()) return bad("target_N_m", "not a finite number");
  if (!(control_period_s >= 0.001)) return bad("control_period_s", "must be >= 0.001 s");
  if (!(time_limit_s > 0.0)) return bad("time_limit_s", "must be > 0 s");
  if (!(settle_s >= 0.0)) return bad("settle_s", "must be >= 0 s");
  if (!(start_offset_m >= 0.0)) return bad("start_offset_m", "must be >= 0 m");
  if (!(acceptance_m > 0.0)) return bad("acceptance_m", "must be > 0 m");
  if (!(max_rate_radps > 0.0)) return bad("max_rate_radps", "must be > 0 rad/s");
  if (!(max_tilt_rad > 0.0 && max_tilt_rad < 1.5)) return bad("max_tilt_rad", "must be in (0, 1.5) rad");
  if (!(terminate_tilt_deg > 0.0 && terminate_tilt_deg <= 180.0)) return bad("terminate_tilt_deg", "must be in (0, 180]");
  if (!std::isfinite(ground_margin_m)) return bad("ground_margin_m", "not a finite number");
  for (double w : {rate_weight, cross_track_weight, effort_weight, progress_weight}) {
    if (!(w >= 0.0 && std::isfinite(w))) return bad("reward weights", "must be finite and >= 0");
  }
  return Status::Ok();
}

VehicleLayout LayoutOf(const sim::RunSetup& setup) {
  const vehicle::VehicleParams& v = setup.vehicle;
  VehicleLayout out;
  out.rotors = v.rotors.size();
  for (const auto& r : v.rotors) {
    out.rotor_p_B_m.push_back(r.position_B_m);
    out.spin.push_back(r.spin);
  }
  out.mixer = control::AllocationMatrix(sim::MixerGeometry(v));
  const control::VehicleModelForControl model = sim::ControlModelFor(v);
  out.mass_kg = model.mass_kg;
  out.inertia_kgm2 = model.inertia_kgm2;
  out.hover_thrust_N = model.mass_kg * kGravity_mps2;
  out.max_thrust_N = model.max_thrust_N;
  // Bisection on the equal command (the total thrust rises with it); 1 when even full command is short.
  double lo = 0.0, hi = 1.0;
  if (TotalThrustN(v, hi) <= out.hover_thrust_N) {
    out.hover_command = 1.0;
    return out;
  }
  for (int i = 0; i < 50; ++i) {
    const double mid = 0.5 * (lo + hi);
    (TotalThrustN(v, mid) < out.hover_thrust_N ? lo : hi) = mid;
  }
  out.hover_command = 0.5 * (lo + hi);
  return out;
}

Env::Env(const sim::RunSetup& setup, const EnvOptions& options)
    : setup_(setup), options_(options), layout_(LayoutOf(setup)), stream_(0, "envs.episode"),
      action_(std::make_unique<Action>()) {
  setup_.options.write_log = false;  // the agent reads the state, not the log
  steps_per_action_ = std::max(1, static_cast<int>(std::lround(options_.control_period_s / setup_.options.physics_dt_s)));
  const size_t base = options_.observe == ObsSource::kSensors ? 17 : 16;
  obs_size_ = base + (options_.task == Task::kHover ? 0 : 3);
  if (options_.act == ActMode::kMotors) {
    action_low_.assign(layout_.rotors, 0.0);
    action_high_.assign(layout_.rotors, 1.0);
  } else {
    action_low_ = {-1.0, -1.0, -1.0, 0.0};
    action_high_ = {1.0, 1.0, 1.0, 1.0};
  }
  clipped_.resize(action_low_.size());
}

Result<std::unique_ptr<Env>> Env::Create(const sim::RunSetup& setup, const EnvOptions& options) {
  if (Status s = options.Validate(); !s.ok()) return s;
  if (Status s = sim::ValidateRunSetup(setup); !s.ok()) return s;
  if (setup.vehicle.rotors.empty() || setup.vehicle.compasses.empty()) {
    return Status::BadInput("vehicle: an environment needs rotors and at least one compass");
  }
  return std::unique_ptr<Env>(new Env(setup, options));
}

Status Env::Reset(uint64_t seed, double* obs) {
  stream_ = RngStream(seed, "envs.episode");
  return BeginEpisode(obs);
}

Status Env::Reset(double* obs) { return BeginEpisode(obs); }

Status Env::BeginEpisode(double* obs) {
  over_ = true;
  sim_.reset();
  sim_seed_ = stream_.NextU64() >> 11;  // 53 bits: exact as a Python int and as a double
  Eigen::Vector3d offset_m;
  for (int k = 0; k < 3; ++k) offset_m[k] = (2.0 * stream_.Uniform() - 1.0) * options_.start_offset_m;
  setup_.options.seed = sim_seed_;
  setup_.options.duration_s = options_.settle_s + options_.time_limit_s + 1.0;
  *action_ = Action{};
  action_->mode = ActMode::kBuiltin;  // on the ground until the estimator has aligned
  action_->p_sp_N_m = options_.target_N_m + offset_m;
  action_->motors.assign(layout_.rotors, 0.0);
  auto created = sim::Simulation::Create(setup_, ActPlugins(setup_, action_.get()));
  if (!created.ok()) return created.status();
  sim_ = std::move(created).value();
  ground_D_m_ = sim_->true_state().p_N_m.z();
  const auto settle_steps = std::lround(options_.settle_s / setup_.options.physics_dt_s);
  for (long i = 0; i < settle_steps; ++i) {
    if (i > 0 && action_->mode == ActMode::kBuiltin && sim_->estimate().healthy) action_->mode = ActMode::kPosition;
    if (!sim_->Step()) {
      return Status::Numerical("settle: the simulation ended while settling at the start point (seed " +
                               std::to_string(sim_seed_) + ")");
    }
  }
  t0_s_ = sim_->time_s();
  index_ = 0;
  success_ = false;
  CrossTrack(sim_->true_state().p_N_m, &along_m_);
  over_ = false;
  Observe(obs);
  return Status::Ok();
}

size_t Env::WaypointCount() const { return options_.task == Task::kHover ? 0 : options_.waypoints_N_m.size(); }

Eigen::Vector3d Env::Target() const {
  return options_.task == Task::kHover ? options_.target_N_m : options_.waypoints_N_m[index_];
}

Eigen::Vector3d Env::LegStart() const {
  return index_ == 0 ? options_.target_N_m : options_.waypoints_N_m[index_ - 1];
}

// Horizontal distance of p from the line LegStart → Target, and the along-leg position.
double Env::CrossTrack(const Eigen::Vector3d& p_N_m, double* along_m) const {
  *along_m = 0.0;
  if (options_.task == Task::kHover) return 0.0;
  const Eigen::Vector2d a = LegStart().head<2>(), b = Target().head<2>(), r = p_N_m.head<2>() - a;
  const double length_m = (b - a).norm();
  if (length_m < 1e-9) return r.norm();
  const Eigen::Vector2d u = (b - a) / length_m;
  *along_m = r.dot(u);
  return (r - *along_m * u).norm();
}

void Env::ApplyAction(const double* action) {
  for (size_t i = 0; i < clipped_.size(); ++i) {  // NaN reads as the lower bound
    const double a = action[i];
    clipped_[i] = !(a >= action_low_[i]) ? action_low_[i] : (a > action_high_[i] ? action_high_[i] : a);
  }
  const double* a = clipped_.data();
  switch (options_.act) {
    case ActMode::kMotors:
      action_->motors.assign(clipped_.begin(), clipped_.end());
      action_->mode = ActMode::kMotors;
      break;
    case ActMode::kRates:
      action_->w_sp_B_radps = Eigen::Vector3d(a[0], a[1], a[2]) * options_.max_rate_radps;
      action_->thrust_N = a[3] * layout_.max_thrust_N;
      action_->mode = ActMode::kRates;
      break;
    default: {  // attitude: roll, pitch (× max_tilt_rad), yaw (× π), collective
      const double roll = a[0] * options_.max_tilt_rad, pitch = a[1] * options_.max_tilt_rad, yaw = a[2] * kPi;
      action_->q_sp_NB = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                         Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                         Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
      action_->thrust_N = a[3] * layout_.max_thrust_N;
      action_->mode = ActMode::kAttitude;
    }
  }
}

StepOutput Env::Step(const double* action, double* obs) {
  HEXSIM_CHECK(!over_ && sim_ != nullptr);
  ApplyAction(action);
  bool alive = true;
  for (int k = 0; k < steps_per_action_ && alive; ++k) alive = sim_->Step();
  const sim::BodyState& s = sim_->true_state();
  StepOutput out;
  if (options_.task == Task::kCompassWaypoint) {
    double along_m = 0.0;
    const double xt_m = CrossTrack(s.p_N_m, &along_m);
    double effort = 0.0;
    for (double u : sim_->motor_commands()) effort += (u - layout_.hover_command) * (u - layout_.hover_command);
    out.reward = -(options_.cross_track_weight * xt_m * xt_m + options_.effort_weight * effort) +
                 options_.progress_weight * (along_m - along_m_);
    along_m_ = along_m;
  } else {
    const Eigen::Vector3d e = Target() - s.p_N_m;
    out.reward = -(e.squaredNorm() + options_.rate_weight * s.w_B_radps.squaredNorm());
  }
  const double height_m = ground_D_m_ - s.p_N_m.z();
  out.terminated = !alive || !s.p_N_m.allFinite() || TiltDeg(s.q_NB) > options_.terminate_tilt_deg ||
                   height_m < options_.ground_margin_m;
  if (WaypointCount() > 0 && (Target() - s.p_N_m).norm() < options_.acceptance_m) {
    if (index_ + 1 == WaypointCount()) {
      success_ = !out.terminated;
      out.terminated = true;
    } else {
      ++index_;
      CrossTrack(s.p_N_m, &along_m_);  // progress counts along the new leg from here
    }
  }
  const bool time_up = sim_->time_s() - t0_s_ >= options_.time_limit_s - 1e-9;
  out.truncated = !out.terminated && time_up;
  if (options_.task == Task::kHover && out.truncated) {
    success_ = (Target() - s.p_N_m).norm() < options_.acceptance_m;
  }
  over_ = out.terminated || out.truncated;
  Observe(obs);
  return out;
}

void Env::Observe(double* obs) const {
  const sim::BodyState& s = sim_->true_state();
  const vehicle::SensorReadings& r = sim_->sensors();
  const Eigen::Vector3d target = Target();
  const Eigen::Vector3d& raw_uT = r.mag_uT[0].value;
  Eigen::Vector3d mag_uT = raw_uT;
  if (options_.observe != ObsSource::kTruth && setup_.compensator) {  // what the estimator is fed
    const std::vector<double>& u = sim_->motor_commands();
    const Eigen::Map<const Eigen::VectorXd> commands(u.data(), static_cast<Eigen::Index>(u.size()));
    mag_uT = setup_.compensator->Correct(raw_uT, {control::ControlAmount(commands), sim_->currents().battery_A});
  }
  double* o = obs;
  switch (options_.observe) {
    case ObsSource::kTruth:
      o = Put(Eigen::Vector3d(target - s.p_N_m), o);
      o = Put(s.v_N_mps, o);
      o = Put(s.q_NB, o);
      o = Put(s.w_B_radps, o);
      o = Put(mag_uT, o);
      break;
    case ObsSource::kEstimator: {
      const nav::NavEstimate& e = sim_->estimate();
      o = Put(Eigen::Vector3d(target - e.p_N_m), o);
      o = Put(e.v_N_mps, o);
      o = Put(e.q_NB, o);
      o = Put(e.w_B_radps, o);
      o = Put(mag_uT, o);
      break;
    }
    case ObsSource::kSensors:
      o = Put(Eigen::Vector3d(target - r.gps.p_N_m), o);
      o = Put(r.gps.v_N_mps, o);
      o = Put(r.gyro_radps.value, o);
      o = Put(r.accel_mps2.value, o);
      o = Put(mag_uT, o);
      *o++ = (ground_D_m_ - target.z()) - r.baro.alt_m;  // height error, up positive (m)
      *o++ = sim_->currents().battery_A;
      break;
  }
  if (options_.task == Task::kWaypoint) {  // the next waypoint relative to the current one
    const bool last = index_ + 1 >= WaypointCount();
    o = Put(last ? Eigen::Vector3d::Zero() : Eigen::Vector3d(options_.waypoints_N_m[index_ + 1] - target), o);
  } else if (options_.task == Task::kCompassWaypoint) {  // the leg's unit direction (NED)
    const Eigen::Vector3d leg = target - LegStart();
    o = Put(leg.norm() > 1e-9 ? Eigen::Vector3d(leg.normalized()) : Eigen::Vector3d::Zero(), o);
  }
  HEXSIM_CHECK(static_cast<size_t>(o - obs) == obs_size_);
}

void Env::Info(double* info) const {
  const sim::BodyState& s = sim_->true_state();
  double along_m = 0.0;
  const double yaw_true = YawOf(s.q_NB), yaw_est = YawOf(sim_->estimate().q_NB);
  info[kInfoTime] = sim_->time_s() - t0_s_;
  info[kInfoPositionError] = (Target() - s.p_N_m).norm();
  info[kInfoBatteryA] = sim_->currents().battery_A;
  info[kInfoTiltDeg] = TiltDeg(s.q_NB);
  info[kInfoHeightM] = ground_D_m_ - s.p_N_m.z();
  info[kInfoWaypointIndex] = static_cast<double>(index_);
  info[kInfoIsSuccess] = success_ ? 1.0 : 0.0;
  info[kInfoCrossTrackM] = CrossTrack(s.p_N_m, &along_m);
  info[kInfoYawTrueDeg] = yaw_true * kRadToDeg;
  info[kInfoYawEstDeg] = yaw_est * kRadToDeg;
  info[kInfoYawErrorDeg] = WrapDeg180((yaw_est - yaw_true) * kRadToDeg);
  info[kInfoTrueN] = s.p_N_m.x();
  info[kInfoTrueE] = s.p_N_m.y();
  info[kInfoTrueD] = s.p_N_m.z();
}

}  // namespace hexsim::envs
