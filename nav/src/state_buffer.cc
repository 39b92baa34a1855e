#include "state_buffer.h"

#include <algorithm>

#include "hexsim/common/rotation.h"

namespace hexsim::nav::internal {

void StateBuffer::Push(double t_s, const Eigen::Vector3d& p_N_m, const Eigen::Vector3d& v_N_mps) {
  if (size_ > 0 && t_s - Slot(size_ - 1).t_s < kInterval_s) return;
  Entry& e = data_[head_];
  e.t_s = t_s;
  e.p_N_m = p_N_m;
  e.v_N_mps = v_N_mps;
  e.applied = shift_count_;  // earlier corrections were made before this state existed
  head_ = (head_ + 1) % kCapacity;
  if (size_ < kCapacity) ++size_;
}

void StateBuffer::Settle(Entry* e) const {
  for (; e->applied < shift_count_; ++e->applied) {
    const Correction& c = log_[e->applied % kShiftCapacity];
    e->p_N_m += c.dp_N_m;
    e->v_N_mps += c.dv_N_mps;
  }
}

bool StateBuffer::Lookup(double t_s, double t_now_s, const Eigen::Vector3d& p_now,
                         const Eigen::Vector3d& v_now, Eigen::Vector3d* p_N_m,
                         Eigen::Vector3d* v_N_mps) const {
  if (t_s >= t_now_s || size_ == 0) {
    if (t_now_s - t_s > 0.0) return false;  // empty buffer, delayed sample: nothing to compare with
    *p_N_m = p_now;
    *v_N_mps = v_now;
    return true;
  }
  if (t_s < Slot(0).t_s) return false;
  // Binary search for the last entry with t <= t_s.
  std::size_t lo = 0, hi = size_;  // invariant: Slot(lo).t <= t_s, answer in [lo, hi)
  while (hi - lo > 1) {
    const std::size_t mid = (lo + hi) / 2;
    if (Slot(mid).t_s <= t_s) lo = mid; else hi = mid;
  }
  Entry& a = Slot(lo);
  Settle(&a);
  const bool has_next = lo + 1 < size_;
  if (has_next) Settle(&Slot(lo + 1));
  const double t_b = has_next ? Slot(lo + 1).t_s : t_now_s;
  const Eigen::Vector3d& p_b = has_next ? Slot(lo + 1).p_N_m : p_now;
  const Eigen::Vector3d& v_b = has_next ? Slot(lo + 1).v_N_mps : v_now;
  const double span = t_b - a.t_s;
  const double w = span > 0 ? (t_s - a.t_s) / span : 0.0;
  *p_N_m = (1.0 - w) * a.p_N_m + w * p_b;
  *v_N_mps = (1.0 - w) * a.v_N_mps + w * v_b;
  return true;
}

void StateBuffer::Shift(const Eigen::Vector3d& dp_N_m, const Eigen::Vector3d& dv_N_mps) {
  if (shift_count_ - settled_ == kShiftCapacity) {
    // The log is full: the slot written next holds correction shift_count_ - kShiftCapacity. Only
    // an entry still missing that one needs settling (applying in order, as a lookup would: the
    // same bits); entries live 1.28 s, so at ordinary fusion rates none does and this is a scan.
    std::uint64_t oldest = shift_count_;
    for (std::size_t i = 0; i < size_; ++i) {
      Entry& e = Slot(i);
      if (e.applied == settled_) Settle(&e);
      oldest = std::min(oldest, e.applied);
    }
    settled_ = oldest;
  }
  Correction& c = log_[shift_count_ % kShiftCapacity];
  c.dp_N_m = dp_N_m;
  c.dv_N_mps = dv_N_mps;
  ++shift_count_;
}

void StaticAligner::AddImu(const ImuSample& s) {
  if (!started) {
    started = true;
    start_t_s = s.t_s;
  }
  sum_accel_B_mps2 += s.accel_B_mps2;
  sum_gyro_B_radps += s.gyro_B_radps;
  ++imu_count;
}

Eigen::Quaterniond StaticAligner::Attitude(const EarthFieldReference& earth) const {
  const Eigen::Vector3d f = sum_accel_B_mps2 / static_cast<double>(imu_count);
  const double roll = std::atan2(-f.y(), -f.z());
  const double pitch = std::atan2(f.x(), std::hypot(f.y(), f.z()));
  const Eigen::Vector3d m = sum_mag_B_uT / static_cast<double>(mag_count);
  const double yaw = TiltCompensatedHeadingRad(m, roll, pitch) + DeclinationRad(earth);
  return QuatFromEuler(roll, pitch, WrapPi(yaw));
}

bool AllFinite(const ImuSample& s) {
  return std::isfinite(s.t_s) && s.gyro_B_radps.allFinite() && s.accel_B_mps2.allFinite();
}

}  // namespace hexsim::nav::internal
