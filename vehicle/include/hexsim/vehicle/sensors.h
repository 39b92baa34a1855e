// Sensors: gyro, accelerometer, compasses, GPS, barometer. Each has its own rate, white noise, a
// constant bias drawn once from its std and a bias random walk, all from its own seeded
// hexsim::RngStream ("gyro", "accel", "mag1", "mag2", ..., "gps", "gps_vel", "baro"), so adding a
// sensor never changes another one's noise. Slower sensors hold their latest sample; each reading
// says whether it is fresh this step and when it was taken.
//
// Compass i: H = ApplyCompassError(R_NB^T*B_N + CurrentDrivenField_uT(p_i, lagged currents), I_batt)
//              + bias + noise.
#pragma once

#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "hexsim/common/rng.h"
#include "hexsim/common/status.h"
#include "hexsim/magnetics/current_field.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::vehicle {

// The true state the sensors see at one physics step.
struct SensorTruth {
  double t_s = 0.0;
  Eigen::Vector3d p_N_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_N_mps = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_NB = Eigen::Quaterniond::Identity();
  Eigen::Vector3d w_B_radps = Eigen::Vector3d::Zero();
  Eigen::Vector3d specific_force_B_mps2 = Eigen::Vector3d::Zero();  // (a - g) in body; at rest (0,0,-9.8)
  Eigen::Vector3d B_earth_N_uT = Eigen::Vector3d::Zero();
  magnetics::Currents currents;  // battery and per-motor DC currents (motor_A sized as the rotors)
};

inline constexpr double kNoSample = std::numeric_limits<double>::quiet_NaN();

struct Vec3Reading {
  bool fresh = false;     // sampled at this step
  bool valid = false;     // at least one sample so far
  double t_s = kNoSample;  // when the held sample was taken
  Eigen::Vector3d value = Eigen::Vector3d::Zero();
};

struct GpsReading {
  bool fresh = false;
  bool valid = false;
  double t_s = kNoSample;            // the measurement epoch (output time minus latency)
  double available_t_s = kNoSample;  // when the receiver delivered it
  Eigen::Vector3d p_N_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_N_mps = Eigen::Vector3d::Zero();
};

struct BaroReading {
  bool fresh = false;
  bool valid = false;
  double t_s = kNoSample;
  double alt_m = 0.0;  // height above the start point, up positive (= -p_D + errors)
};

struct SensorReadings {
  Vec3Reading gyro_radps;
  Vec3Reading accel_mps2;
  std::vector<Vec3Reading> mag_uT;  // one per VehicleParams::compasses, same order
  GpsReading gps;
  BaroReading baro;
};

// The noise-free compass model: the reading compass `c` gives for attitude q_NB, Earth field B_N and
// (already lagged) currents.
Eigen::Vector3d CompassNoiseFree_uT(const CompassParams& c, const magnetics::CurrentFieldParams& wiring,
                                    const Eigen::Quaterniond& q_NB, const Eigen::Vector3d& B_earth_N_uT,
                                    const magnetics::Currents& currents);

// One noisy channel: periodic sampling, bias (initial + random walk) and white noise per axis.
class NoiseChannel {
 public:
  NoiseChannel() = default;
  NoiseChannel(double rate_hz, const Eigen::Vector3d& noise_std, const Eigen::Vector3d& bias_std,
               const Eigen::Vector3d& bias_walk_per_sqrt_s, uint64_t seed, std::string_view stream);
  // True when a sample is due at t_s (the first step always samples; then every 1/rate).
  // A small tolerance keeps t = k/rate sampled despite rounding in the caller's clock. Inline:
  // five channels ask every physics step.
  bool Due(double t_s) const { return !started_ || t_s >= next_t_s_ - 1e-9 * period_s_; }
  // Takes a sample at t_s: advances the bias walk and returns truth + bias + noise.
  Eigen::Vector3d Sample(double t_s, const Eigen::Vector3d& truth);
  const Eigen::Vector3d& bias() const { return bias_; }

 private:
  double period_s_ = 0.0;
  Eigen::Vector3d noise_std_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d walk_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d bias_ = Eigen::Vector3d::Zero();
  RngStream rng_;
  bool started_ = false;
  double last_t_s_ = 0.0;
  double next_t_s_ = 0.0;
};

class SensorSuite {
 public:
  // Validates what the suite needs (rates, wiring indices against the rotor count).
  static Result<SensorSuite> Create(const VehicleParams& params, uint64_t seed);

  // Advances every sensor to truth.t_s (non-decreasing between calls) and returns the readings:
  // sensors due at this step are fresh, the others hold their latest sample.
  const SensorReadings& Step(const SensorTruth& truth);
  const SensorReadings& readings() const { return readings_; }

  // The current biases (for evaluation and tests; an estimator must not read them).
  const Eigen::Vector3d& gyro_bias_radps() const { return gyro_.bias(); }
  const Eigen::Vector3d& accel_bias_mps2() const { return accel_.bias(); }
  const Eigen::Vector3d& mag_bias_uT(size_t i) const { return mags_[i].channel.bias(); }

 private:
  struct History {
    double t_s;
    Eigen::Vector3d p_N_m, v_N_mps;
  };
  // FIFO of the GPS truth history: a ring that doubles when full, so steady stepping allocates
  // nothing (a deque allocated and freed a block every few steps).
  class HistoryRing {
   public:
    size_t size() const { return size_; }
    const History& operator[](size_t i) const { return buf_[(head_ + i) & (buf_.size() - 1)]; }
    const History& front() const { return (*this)[0]; }
    void pop_front() {
      head_ = (head_ + 1) & (buf_.size() - 1);
      --size_;
    }
    void push_back(const History& h) {
      if (size_ == buf_.size()) Grow();
      buf_[(head_ + size_) & (buf_.size() - 1)] = h;
      ++size_;
    }

   private:
    void Grow() {  // capacity stays a power of two; the entries move to the front in order
      std::vector<History> next(buf_.empty() ? 64 : 2 * buf_.size());
      for (size_t i = 0; i < size_; ++i) next[i] = (*this)[i];
      buf_ = std::move(next);
      head_ = 0;
    }
    std::vector<History> buf_;
    size_t head_ = 0;
    size_t size_ = 0;
  };
  struct Compass {
    CompassParams params;
    magnetics::CurrentFieldParams wiring;  // the vehicle's, with this compass' lag
    magnetics::CurrentLagState lag;
    magnetics::FixedPointCurrentField field;  // the wiring's field at this compass, geometry folded
    NoiseChannel channel;
  };
  SensorSuite() = default;

  std::vector<Compass> mags_;
  size_t rotor_count_ = 0;
  NoiseChannel gyro_, accel_, gps_pos_, gps_vel_, baro_;
  double gps_latency_s_ = 0.0;
  HistoryRing history_;
  bool stepped_ = false;
  double last_t_s_ = 0.0;
  SensorReadings readings_;
};

}  // namespace hexsim::vehicle
