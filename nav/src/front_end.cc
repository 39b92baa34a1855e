#include "front_end.h"

#include <cmath>
#include <cstdio>

namespace hexsim::nav::internal {

void FrontEnd::Reset(const NavEstimate& initial) {
  t_s_ = initial.t_s;
  have_time_ = false;
  aligning_ = !initial.healthy;
  aligner_.Clear();
  buffer_.Clear();
  stats_ = EstimatorStats();
  health_ = Status::Ok();
}

bool FrontEnd::AdmitImu(const ImuSample& s, double align_time_s, Filter* filter) {
  if (!health_.ok()) return false;
  ++stats_.imu_samples;
  if (!AllFinite(s) || (have_time_ && s.t_s <= t_s_)) {
    ++stats_.imu_rejected_invalid;
    return false;
  }
  if (aligning_) {
    aligner_.AddImu(s);
    t_s_ = s.t_s;
    have_time_ = true;
    return FinishIfAligned(align_time_s, filter);
  }
  if (!have_time_) {
    t_s_ = s.t_s;
    have_time_ = true;
    filter->OnFirstImu(s);
    return false;
  }
  return true;
}

bool FrontEnd::AdmitMag(const MagSample& s, double align_time_s, Filter* filter) {
  if (!health_.ok()) return false;
  if (!std::isfinite(s.t_s) || !s.mag_B_uT.allFinite() || s.mag_B_uT.squaredNorm() == 0.0) {
    ++stats_.mag.rejected_invalid;
    return false;
  }
  if (aligning_) {
    aligner_.AddMag(s);
    return FinishIfAligned(align_time_s, filter);
  }
  return true;
}

bool FrontEnd::AdmitGps(const GpsSample& s) {
  if (!health_.ok()) return false;
  if (!std::isfinite(s.t_s) || !s.p_N_m.allFinite() || !s.v_N_mps.allFinite()) {
    ++stats_.gps_pos.rejected_invalid;
    ++stats_.gps_vel.rejected_invalid;
    return false;
  }
  return !aligning_ && have_time_;  // nothing to compare with before
}

bool FrontEnd::AdmitBaro(const BaroSample& s) {
  if (!health_.ok()) return false;
  if (!std::isfinite(s.t_s) || !std::isfinite(s.alt_m)) {
    ++stats_.baro.rejected_invalid;
    return false;
  }
  return !aligning_ && have_time_;
}

void FrontEnd::FinishAlignment(const Eigen::Vector3d& p_N_m, const Eigen::Vector3d& v_N_mps) {
  aligning_ = false;
  buffer_.Clear();
  buffer_.Push(t_s_, p_N_m, v_N_mps);
}

bool FrontEnd::LookupForGps(double t_s, const Eigen::Vector3d& p_now, const Eigen::Vector3d& v_now,
                            Eigen::Vector3d* p_then, Eigen::Vector3d* v_then) {
  if (Lookup(t_s, p_now, v_now, p_then, v_then)) return true;
  ++stats_.gps_pos.rejected_invalid;
  ++stats_.gps_vel.rejected_invalid;
  return false;
}

bool FrontEnd::CheckSpeed(const Eigen::Vector3d& v_N_mps, double t_s, const char* where) {
  if (SpeedOk(v_N_mps)) return true;
  Fail("diverged: |v_N_mps| = " + Num(v_N_mps.norm()) + " m/s at t=" + Num(t_s) + " s" + Where(where));
  return false;
}

std::string FrontEnd::Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.4f", v);
  return buf;
}

}  // namespace hexsim::nav::internal
