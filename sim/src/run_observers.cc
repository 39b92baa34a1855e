// The observers of a run: the FlightLog recorder and the scorer (step_record.h).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include <fmt/format.h>

#include "hexsim/common/rotation.h"
#include "hexsim/sim/step_record.h"

namespace hexsim::sim {

namespace {

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

// Bitwise equality (NaN equals NaN of the same bits, 0 differs from -0): the same input to YawDegFast.
bool SameBits(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  for (int i = 0; i < 4; ++i) {
    std::uint64_t x = 0, y = 0;
    std::memcpy(&x, &a.coeffs()[i], sizeof x);
    std::memcpy(&y, &b.coeffs()[i], sizeof y);
    if (x != y) return false;
  }
  return true;
}

}  // namespace

// The same rotation-matrix entries as Eigen's toRotationMatrix, the same wraps; the yaw-error
// statistics take two yaws every step.
double YawDegFast(const Eigen::Quaterniond& q_in) {
  const Eigen::Quaterniond q = q_in.normalized();
  const double ty = 2.0 * q.y(), tz = 2.0 * q.z();
  const double r10 = ty * q.x() + tz * q.w();
  const double r00 = 1.0 - (ty * q.y() + tz * q.z());
  return WrapDeg180Fast(WrapPiFast(std::atan2(r10, r00)) * kRadToDeg);
}

// --- LogRecorder ---------------------------------------------------------------------------------

LogRecorder::LogRecorder(logs::FlightLog* log, size_t rotors, size_t compasses, int log_every)
    : log_(log), log_every_(std::max(1, log_every)) {
  auto add = [&](const std::string& n) { return log->AddColumn(n); };
  t_ = add("t_s");
  const char* ned[3] = {"N", "E", "D"};
  const char* xyz[3] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) pos_[i] = add(fmt::format("pos_{}_m", ned[i]));
  for (int i = 0; i < 3; ++i) vel_[i] = add(fmt::format("vel_{}_mps", ned[i]));
  const char* wxyz[4] = {"w", "x", "y", "z"};
  for (int i = 0; i < 4; ++i) q_[i] = add(fmt::format("q_{}", wxyz[i]));
  for (int i = 0; i < 3; ++i) gyro_[i] = add(fmt::format("gyro_{}_radps", xyz[i]));
  for (int i = 0; i < 3; ++i) accel_[i] = add(fmt::format("accel_{}_mps2", xyz[i]));
  for (size_t c = 0; c < compasses; ++c) {
    const std::string pre = c == 0 ? "mag" : fmt::format("mag{}", c + 1);
    mag_.push_back({add(pre + "_x_uT"), add(pre + "_y_uT"), add(pre + "_z_uT"), add(pre + "_t_s")});
  }
  baro_ = add("baro_alt_m");
  baro_t_ = add("baro_t_s");
  for (int i = 0; i < 3; ++i) gps_[i] = add(fmt::format("gps_{}_m", ned[i]));
  for (int i = 0; i < 3; ++i) gps_vel_[i] = add(fmt::format("gps_vel_{}_mps", ned[i]));
  gps_t_ = add("gps_t_s");
  control_u_ = add("control_u");
  current_ = add("current_A");
  voltage_ = add("voltage_V");
  soc_ = add("battery_soc");
  for (size_t i = 0; i < rotors; ++i) motor_u_.push_back(add(fmt::format("motor_{}_u", i + 1)));
  for (size_t i = 0; i < rotors; ++i) motor_A_.push_back(add(fmt::format("motor_{}_A", i + 1)));
  esc_limited_ = add("esc_limited");
  batt_limited_ = add("batt_limited");
  for (int i = 0; i < 4; ++i) est_q_[i] = add(fmt::format("est_q_{}", wxyz[i]));
  for (int i = 0; i < 3; ++i) est_pos_[i] = add(fmt::format("est_pos_{}_m", ned[i]));
  for (int i = 0; i < 3; ++i) est_vel_[i] = add(fmt::format("est_vel_{}_mps", ned[i]));
  yaw_true_ = add("yaw_true_deg");
  yaw_est_ = add("yaw_est_deg");
  mode_ = add("mode");
  wp_ = add("waypoint_index");
  for (int i = 0; i < 3; ++i) wind_[i] = add(fmt::format("wind_{}_mps", ned[i]));
  payload_ = add("payload_kg");
}

void LogRecorder::EnableStreams(double rate_hz) {
  stream_period_s_ = rate_hz > 0 ? 1.0 / rate_hz : -1.0;
  const char* xyz[3] = {"x", "y", "z"};
  imu_.table.AddColumn("t_s");
  for (const char* a : xyz) imu_.table.AddColumn(fmt::format("gyro_{}_radps", a));
  for (const char* a : xyz) imu_.table.AddColumn(fmt::format("accel_{}_mps2", a));
  rcou_.table.AddColumn("t_s");
  for (size_t i = 0; i < motor_u_.size(); ++i) rcou_.table.AddColumn(fmt::format("motor_{}_u", i + 1));
  for (const char* c : {"t_s", "current_A", "voltage_V"}) batt_.table.AddColumn(c);
}

bool LogRecorder::Stream::Due(double t_s, double period_s) {
  if (t_s + 1e-9 < next_t_s) return false;
  // Stay on the grid of kept times; restart it when behind (the first sample, a gap).
  next_t_s = next_t_s + period_s > t_s ? next_t_s + period_s : t_s + period_s;
  table.AppendRow();
  return true;
}

void LogRecorder::AttachStreams() {
  if (stream_period_s_ < 0) return;
  log_->SetStream("imu", std::move(imu_.table));
  log_->SetStream("rcou", std::move(rcou_.table));
  log_->SetStream("batt", std::move(batt_.table));
  stream_period_s_ = -1.0;
}

void LogRecorder::OnStep(const StepRecord& r) {
  if (stream_period_s_ > 0) {
    const vehicle::SensorReadings& rd = *r.readings;
    if (rd.gyro_radps.fresh && imu_.Due(rd.gyro_radps.t_s, stream_period_s_)) {
      imu_.table.Set(size_t{0}, rd.gyro_radps.t_s);
      for (size_t i = 0; i < 3; ++i) {
        imu_.table.Set(1 + i, rd.gyro_radps.value[static_cast<int>(i)]);
        imu_.table.Set(4 + i, rd.accel_mps2.value[static_cast<int>(i)]);
      }
    }
    if (rcou_.Due(r.t_s, stream_period_s_)) {
      rcou_.table.Set(size_t{0}, r.t_s);
      for (size_t i = 0; i < motor_u_.size(); ++i) rcou_.table.Set(1 + i, (*r.commands)[i]);
    }
    if (batt_.Due(r.t_s, stream_period_s_)) {
      batt_.table.Set(size_t{0}, r.t_s);
      batt_.table.Set(size_t{1}, r.battery_A);
      batt_.table.Set(size_t{2}, r.powertrain->motors.empty() ? r.nominal_V : r.powertrain->bus_V);
    }
  }
  if (r.step % log_every_ != 0) return;
  logs::FlightLog& log = *log_;
  const BodyState& s = *r.truth;
  const nav::NavEstimate& est = *r.estimate;
  const vehicle::SensorReadings& rd = *r.readings;
  const vehicle::PowertrainOutput& pt = *r.powertrain;
  log.AppendRow();
  log.Set(t_, r.t_s);
  for (int i = 0; i < 3; ++i) {
    log.Set(pos_[i], s.p_N_m[i]);
    log.Set(vel_[i], s.v_N_mps[i]);
    log.Set(est_pos_[i], est.p_N_m[i]);
    log.Set(est_vel_[i], est.v_N_mps[i]);
    log.Set(wind_[i], r.wind_N_mps[i]);
  }
  const double qc[4] = {s.q_NB.w(), s.q_NB.x(), s.q_NB.y(), s.q_NB.z()};
  const double eq[4] = {est.q_NB.w(), est.q_NB.x(), est.q_NB.y(), est.q_NB.z()};
  for (int i = 0; i < 4; ++i) {
    log.Set(q_[i], qc[i]);
    log.Set(est_q_[i], eq[i]);
  }
  if (rd.gyro_radps.valid) {
    for (int i = 0; i < 3; ++i) {
      log.Set(gyro_[i], rd.gyro_radps.value[i]);
      log.Set(accel_[i], rd.accel_mps2.value[i]);
    }
  }
  for (size_t m = 0; m < rd.mag_uT.size() && m < mag_.size(); ++m) {
    if (!rd.mag_uT[m].valid) continue;
    for (int i = 0; i < 3; ++i) log.Set(mag_[m][static_cast<size_t>(i)], rd.mag_uT[m].value[i]);
    log.Set(mag_[m][3], rd.mag_uT[m].t_s);
  }
  if (rd.baro.valid) {
    log.Set(baro_, rd.baro.alt_m);
    log.Set(baro_t_, rd.baro.t_s);
  }
  if (rd.gps.valid) {
    for (int i = 0; i < 3; ++i) {
      log.Set(gps_[i], rd.gps.p_N_m[i]);
      log.Set(gps_vel_[i], rd.gps.v_N_mps[i]);
    }
    log.Set(gps_t_, rd.gps.t_s);
  }
  log.Set(control_u_, r.control_u);
  log.Set(current_, r.battery_A);
  log.Set(voltage_, pt.motors.empty() ? r.nominal_V : pt.bus_V);
  log.Set(soc_, r.soc);
  const std::vector<double>& commands = *r.commands;
  for (size_t i = 0; i < motor_u_.size(); ++i) {
    log.Set(motor_u_[i], commands[i]);
    log.Set(motor_A_[i], pt.motors.empty() ? 0.0 : pt.motors[i].dc_A);
  }
  log.Set(esc_limited_, pt.esc_limited);
  log.Set(batt_limited_, pt.battery_limited ? 1.0 : 0.0);
  log.Set(yaw_true_, YawDegFast(s.q_NB));
  log.Set(yaw_est_, YawDegFast(est.q_NB));
  log.Set(mode_, static_cast<double>(r.mode));
  log.Set(wp_, r.waypoint_index);
  log.Set(payload_, r.payload_kg);
}

// --- RunScorer -----------------------------------------------------------------------------------

void RunningStats::Add(double x) {
  n += 1;
  sum += x;
  sum2 += x * x;
  max = std::max(max, std::fabs(x));
}
double RunningStats::Rms() const { return n > 0 ? std::sqrt(sum2 / n) : 0.0; }
double RunningStats::Mean() const { return n > 0 ? sum / n : 0.0; }

void RunScorer::OnStep(const StepRecord& r) {
  if (r.arrival) {
    arrivals_.push_back({r.arrival->waypoint_index, r.arrival->error_m, r.arrival->t_s});
  }
  const bool airborne = r.mode == control::FlightMode::kWaypoint || r.mode == control::FlightMode::kHold;
  if (airborne && r.active_leg >= 0) cross_track_.Add(control::CrossTrackToLeg(path_, r.active_leg, r.truth->p_N_m));
  // Yaw error is scored like cross-track, on the mission legs (the paper's in-flight figure);
  // yaw_error_all_deg also covers take-off and landing, where the rotor spin-up transient lives.
  if (r.estimated && r.mode != control::FlightMode::kIdle && !r.landed) {
    // The estimate changes only when the autopilot runs (at the IMU rate): its yaw is kept until then.
    if (!SameBits(r.estimate->q_NB, est_q_)) {
      est_q_ = r.estimate->q_NB;
      est_yaw_deg_ = YawDegFast(est_q_);
    }
    const double e = WrapDeg180Fast(est_yaw_deg_ - YawDegFast(r.truth->q_NB));
    yaw_err_all_.Add(e);
    if (airborne) yaw_err_.Add(e);
  }
}

void RunScorer::OnInterval(const StepInterval& iv) {
  energy_J_ += iv.powertrain->power_in_W * iv.dt_s;
  current_.Add(iv.powertrain->battery_A);
  if (iv.powertrain->esc_limited > 0) esc_limited_s_ += iv.dt_s;
  if (iv.powertrain->battery_limited) battery_limited_s_ += iv.dt_s;
  distance_m_ += (iv.p_after_N_m - iv.p_before_N_m).norm();
}

void RunScorer::WriteSummary(RunSummary* summary) const {
  RunSummary& sum = *summary;
  sum.distance_m = distance_m_;
  sum.cross_track_m = {cross_track_.max, cross_track_.Rms()};
  sum.yaw_error_deg = {yaw_err_.max, yaw_err_.Rms()};
  sum.yaw_error_all_deg = {yaw_err_all_.max, yaw_err_all_.Rms()};
  sum.energy_Wh = energy_J_ / 3600.0;
  sum.current_max_A = current_.max;
  sum.current_mean_A = current_.Mean();
  sum.current_limited_esc_s = esc_limited_s_;
  sum.current_limited_battery_s = battery_limited_s_;
  sum.waypoints = arrivals_;
}

}  // namespace hexsim::sim
