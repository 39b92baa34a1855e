// Internal: a fixed-capacity ring of past position/velocity states for delayed measurements, and
// the static-alignment accumulator. Shared by the estimators; not part of the public API.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "hexsim/nav/estimator.h"

namespace hexsim::nav::internal {

// Past (t, p_N, v_N), one entry every kInterval_s: 256 entries hold 1.275 s of history, the
// largest GPS latency the estimators accept. No heap: the storage is member arrays.
//
// Shift() is lazy: a correction is appended to a log and each entry applies the corrections made
// since it was stored, in the order they were made, only when a lookup reads it (or, rarely, when
// the log is full). Every entry therefore holds exactly the sum an eager shift would have given,
// bit for bit, but a fusion costs O(1) instead of touching the whole history.
class StateBuffer {
 public:
  static constexpr std::size_t kCapacity = 256;
  static constexpr std::size_t kShiftCapacity = 1024;  // corrections kept pending (~7 s of fusions)
  static constexpr double kInterval_s = 0.005;

  void Clear() { size_ = 0; head_ = 0; shift_count_ = 0; settled_ = 0; }
  void Push(double t_s, const Eigen::Vector3d& p_N_m, const Eigen::Vector3d& v_N_mps);
  // The state at t_s, linearly interpolated; falls back to (p_now, v_now) at or after `t_now_s`.
  // false when t_s is older than the oldest entry.
  bool Lookup(double t_s, double t_now_s, const Eigen::Vector3d& p_now, const Eigen::Vector3d& v_now,
              Eigen::Vector3d* p_N_m, Eigen::Vector3d* v_N_mps) const;
  // Applies a correction to every stored state, so a later delayed measurement compares against
  // the corrected history and the same error is never corrected twice.
  void Shift(const Eigen::Vector3d& dp_N_m, const Eigen::Vector3d& dv_N_mps);

 private:
  struct Entry {
    double t_s = 0;
    Eigen::Vector3d p_N_m = Eigen::Vector3d::Zero();
    Eigen::Vector3d v_N_mps = Eigen::Vector3d::Zero();
    std::uint64_t applied = 0;  // corrections 0 .. applied-1 of the log are in p_N_m, v_N_mps
  };
  struct Correction {
    Eigen::Vector3d dp_N_m = Eigen::Vector3d::Zero();
    Eigen::Vector3d dv_N_mps = Eigen::Vector3d::Zero();
  };
  Entry& Slot(std::size_t i) const {  // i = 0 is the oldest
    return data_[(head_ + kCapacity - size_ + i) % kCapacity];
  }
  // Brings an entry up to date with every correction made so far (logically const: the value an
  // eager Shift would already hold).
  void Settle(Entry* e) const;

  mutable std::array<Entry, kCapacity> data_{};
  std::array<Correction, kShiftCapacity> log_{};
  std::size_t size_ = 0;
  std::size_t head_ = 0;           // next write slot
  std::uint64_t shift_count_ = 0;  // corrections made since Clear()
  std::uint64_t settled_ = 0;      // every live entry has applied at least this many
};

// Averages IMU and compass samples over the alignment window of a static vehicle.
struct StaticAligner {
  double start_t_s = 0;
  bool started = false;
  Eigen::Vector3d sum_accel_B_mps2 = Eigen::Vector3d::Zero();
  Eigen::Vector3d sum_gyro_B_radps = Eigen::Vector3d::Zero();
  Eigen::Vector3d sum_mag_B_uT = Eigen::Vector3d::Zero();
  long imu_count = 0;
  long mag_count = 0;

  void Clear() { *this = StaticAligner(); }
  void AddImu(const ImuSample& s);
  void AddMag(const MagSample& s) { sum_mag_B_uT += s.mag_B_uT; ++mag_count; }
  bool Ready(double t_now_s, double align_time_s) const {
    return started && imu_count > 0 && mag_count > 0 && t_now_s - start_t_s >= align_time_s;
  }
  // Roll/pitch from the mean specific force f = (g sinθ, −g sinφ cosθ, −g cosφ cosθ), yaw from the
  // tilt-compensated mean field plus declination.
  Eigen::Quaterniond Attitude(const EarthFieldReference& earth) const;
  Eigen::Vector3d GyroBias() const { return sum_gyro_B_radps / static_cast<double>(imu_count); }
};

bool AllFinite(const ImuSample& s);

}  // namespace hexsim::nav::internal
