#include "hexsim/vehicle/sensors.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "hexsim/common/format.h"
#include "hexsim/magnetics/compass_model.h"

namespace hexsim::vehicle {
namespace {

NoiseChannel MakeChannel(double rate_hz, const NoiseParams& xy, const NoiseParams& z, uint64_t seed,
                         std::string_view name) {
  return NoiseChannel(rate_hz, {xy.noise_std, xy.noise_std, z.noise_std}, {xy.bias_std, xy.bias_std, z.bias_std},
                      {xy.bias_walk_per_sqrt_s, xy.bias_walk_per_sqrt_s, z.bias_walk_per_sqrt_s}, seed, name);
}

}  // namespace

namespace {
// H~_B = R_NB^T*B_N + B_current(p);  H = R_SB*(scale*K(I)*H~_B) + beta
Eigen::Vector3d CompassReading_uT(const CompassParams& c, const Eigen::Vector3d& current_B_uT,
                                  const Eigen::Quaterniond& q_NB, const Eigen::Vector3d& B_earth_N_uT,
                                  double battery_A) {
  const Eigen::Vector3d earth_B_uT = q_NB.conjugate() * B_earth_N_uT;
  return magnetics::ApplyCompassError(c.error, earth_B_uT + current_B_uT, battery_A);
}
}  // namespace

Eigen::Vector3d CompassNoiseFree_uT(const CompassParams& c, const magnetics::CurrentFieldParams& wiring,
                                    const Eigen::Quaterniond& q_NB, const Eigen::Vector3d& B_earth_N_uT,
                                    const magnetics::Currents& currents) {
  return CompassReading_uT(c, magnetics::CurrentDrivenField_uT(wiring, c.position_B_m, currents), q_NB, B_earth_N_uT,
                           currents.battery_A);
}

NoiseChannel::NoiseChannel(double rate_hz, const Eigen::Vector3d& noise_std, const Eigen::Vector3d& bias_std,
                           const Eigen::Vector3d& bias_walk_per_sqrt_s, uint64_t seed, std::string_view stream)
    : period_s_(1.0 / rate_hz), noise_std_(noise_std), walk_(bias_walk_per_sqrt_s), rng_(seed, stream) {
  HEXSIM_CHECK(rate_hz > 0.0);
  for (int i = 0; i < 3; ++i) bias_(i) = bias_std(i) * rng_.Normal();
}

Eigen::Vector3d NoiseChannel::Sample(double t_s, const Eigen::Vector3d& truth) {
  if (started_) {
    const double dt = std::max(0.0, t_s - last_t_s_);
    const double sqrt_dt = std::sqrt(dt);
    for (int i = 0; i < 3; ++i) bias_(i) += walk_(i) * sqrt_dt * rng_.Normal();  // b += sigma_w*sqrt(dt)*n
    next_t_s_ += period_s_;
    while (next_t_s_ <= t_s - 1e-9 * period_s_) next_t_s_ += period_s_;  // caller stepped slower than the rate
  } else {
    next_t_s_ = t_s + period_s_;
    started_ = true;
  }
  last_t_s_ = t_s;
  Eigen::Vector3d out = truth + bias_;
  for (int i = 0; i < 3; ++i) out(i) += noise_std_(i) * rng_.Normal();
  return out;
}

Result<SensorSuite> SensorSuite::Create(const VehicleParams& params, uint64_t seed) {
  const int motors = static_cast<int>(params.rotors.size());
  Status wiring_ok = magnetics::ValidateCurrentFieldParams(params.wiring, motors);
  if (!wiring_ok.ok()) return wiring_ok.WithContext(params.name + ": wiring");
  const SensorParams& s = params.sensors;
  for (double rate : {s.gyro.rate_hz, s.accel.rate_hz, s.gps.rate_hz, s.baro.rate_hz}) {
    if (!(rate > 0.0)) return Status::BadInput(params.name + ": sensors: every rate_hz must be > 0");
  }
  SensorSuite suite;
  suite.rotor_count_ = params.rotors.size();
  suite.gyro_ = MakeChannel(s.gyro.rate_hz, s.gyro.noise, s.gyro.noise, seed, "gyro");
  suite.accel_ = MakeChannel(s.accel.rate_hz, s.accel.noise, s.accel.noise, seed, "accel");
  suite.gps_pos_ = MakeChannel(s.gps.rate_hz, s.gps.horizontal_m, s.gps.vertical_m, seed, "gps");
  suite.gps_vel_ = MakeChannel(s.gps.rate_hz, s.gps.velocity_mps, s.gps.velocity_mps, seed, "gps_vel");
  NoiseParams no_noise;
  suite.baro_ = MakeChannel(s.baro.rate_hz, no_noise, s.baro.noise_m, seed, "baro");
  suite.gps_latency_s_ = s.gps.latency_s;
  for (size_t i = 0; i < params.compasses.size(); ++i) {
    const CompassParams& c = params.compasses[i];
    if (!(c.rate_hz > 0.0)) return Status::BadInput(Format("%s: compasses[%zu]: rate_hz must be > 0", params.name.c_str(), i));
    Compass m;
    m.params = c;
    m.wiring = params.wiring;
    if (c.current_lag_tau_s >= 0.0) m.wiring.lag_tau_s = c.current_lag_tau_s;
    m.field = magnetics::FixedPointCurrentField(m.wiring, c.position_B_m);
    m.channel = MakeChannel(c.rate_hz, c.noise, c.noise, seed, "mag" + std::to_string(i + 1));
    suite.mags_.push_back(std::move(m));
  }
  suite.readings_.mag_uT.resize(params.compasses.size());
  return suite;
}

const SensorReadings& SensorSuite::Step(const SensorTruth& truth) {
  const double t = truth.t_s;
  HEXSIM_CHECK(std::isfinite(t));
  HEXSIM_CHECK(!stepped_ || t >= last_t_s_);
  const double dt = stepped_ ? t - last_t_s_ : 0.0;
  stepped_ = true;
  last_t_s_ = t;
  SensorReadings& r = readings_;

  if ((r.gyro_radps.fresh = gyro_.Due(t))) {
    r.gyro_radps.value = gyro_.Sample(t, truth.w_B_radps);
    r.gyro_radps.t_s = t;
    r.gyro_radps.valid = true;
  }
  if ((r.accel_mps2.fresh = accel_.Due(t))) {
    r.accel_mps2.value = accel_.Sample(t, truth.specific_force_B_mps2);
    r.accel_mps2.t_s = t;
    r.accel_mps2.valid = true;
  }

  for (size_t i = 0; i < mags_.size(); ++i) {
    Compass& m = mags_[i];
    // The lag runs every step, whether or not the compass samples now.
    const magnetics::Currents* currents = &truth.currents;
    if (!m.wiring.segments.empty() || !m.wiring.dipoles.empty() || m.params.error.soft_iron_per_A.any()) {
      HEXSIM_CHECK(truth.currents.motor_A.size() == rotor_count_);
      currents = &magnetics::StepCurrentLag(m.wiring, truth.currents, dt, &m.lag);
    }
    Vec3Reading& out = r.mag_uT[i];
    if ((out.fresh = m.channel.Due(t))) {
      out.value = m.channel.Sample(
          t, CompassReading_uT(m.params, m.field(*currents), truth.q_NB, truth.B_earth_N_uT, currents->battery_A));
      out.t_s = t;
      out.valid = true;
    }
  }

  // GPS: keep enough truth history to look back by the latency.
  history_.push_back({t, truth.p_N_m, truth.v_N_mps});
  while (history_.size() > 2 && history_[1].t_s <= t - gps_latency_s_) history_.pop_front();
  r.gps.fresh = false;
  const double epoch = t - gps_latency_s_;
  if (gps_pos_.Due(t) && epoch >= history_.front().t_s - 1e-12) {
    // Linear interpolation of the truth at the epoch (history_ brackets it).
    size_t k = 0;
    while (k + 1 < history_.size() && history_[k + 1].t_s <= epoch) ++k;
    const History& a = history_[k];
    const History& b = history_[std::min(k + 1, history_.size() - 1)];
    const double span = b.t_s - a.t_s;
    const double f = span > 0.0 ? std::clamp((epoch - a.t_s) / span, 0.0, 1.0) : 0.0;
    r.gps.p_N_m = gps_pos_.Sample(t, a.p_N_m + f * (b.p_N_m - a.p_N_m));
    r.gps.v_N_mps = gps_vel_.Sample(t, a.v_N_mps + f * (b.v_N_mps - a.v_N_mps));
    r.gps.t_s = epoch;
    r.gps.available_t_s = t;
    r.gps.fresh = r.gps.valid = true;
  }

  if ((r.baro.fresh = baro_.Due(t))) {
    r.baro.alt_m = baro_.Sample(t, Eigen::Vector3d(0.0, 0.0, -truth.p_N_m.z()))(2);
    r.baro.t_s = t;
    r.baro.valid = true;
  }
  return r;
}

}  // namespace hexsim::vehicle
