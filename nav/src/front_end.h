// Internal: the estimator front end that every filter composes. It owns what is not the filter:
// which samples are admitted (finite, IMU time moving forward), the static alignment before the
// first estimate, the first IMU sample after alignment, the delayed-state buffer behind delayed GPS,
// the per-sensor statistics and the health status. A gating or admission fix is made here once.
//
// A filter implements Filter (what the front end calls when the alignment completes and on the first
// IMU sample after it) and asks before each step:
//   if (!front_.AdmitImu(s, align_time_s, this)) return;  // rejected, absorbed by the alignment, or first
//   /* propagate over s.t_s − front_.time() */ front_.Advance(s.t_s); ... front_.Record(p, v);
#pragma once

#include <cmath>
#include <string>
#include <type_traits>

#include <Eigen/Core>

#include "hexsim/common/status.h"
#include "hexsim/nav/estimator.h"
#include "state_buffer.h"

namespace hexsim::nav::internal {

// A larger IMU gap than this is integrated as this by both filters (a dropped-sample burst must not
// blow up F·dt).
constexpr double kMaxImuDt_s = 0.05;

// What the front end asks of the filter it fronts.
class Filter {
 public:
  virtual ~Filter() = default;
  // The static alignment is complete: initialise attitude and biases from aligner(), then call
  // FrontEnd::FinishAlignment(p, v).
  virtual void OnAligned() = 0;
  // The first IMU sample after the alignment: time is set, there is nothing to integrate yet.
  virtual void OnFirstImu(const ImuSample& s) = 0;
};

class FrontEnd {
 public:
  // `filter_name` prefixes every health message ("eskf: non-finite ...").
  explicit FrontEnd(std::string filter_name) : name_(std::move(filter_name)) {}

  // Forgets everything; aligns first unless `initial` is healthy.
  void Reset(const NavEstimate& initial);

  // true when the filter processes the sample. Otherwise it was rejected, absorbed by the alignment
  // (filter->OnAligned() ran when it completed it) or was the first IMU sample (filter->OnFirstImu(s) ran).
  bool AdmitImu(const ImuSample& s, double align_time_s, Filter* filter);
  bool AdmitMag(const MagSample& s, double align_time_s, Filter* filter);
  // true when the filter may fuse it (valid, aligned, and an IMU time to compare it with).
  bool AdmitGps(const GpsSample& s);
  bool AdmitBaro(const BaroSample& s);

  // The filter has initialised from aligner(): estimation starts from (p, v) at time().
  void FinishAlignment(const Eigen::Vector3d& p_N_m, const Eigen::Vector3d& v_N_mps);
  // The filter's state now refers to t_s.
  void Advance(double t_s) { t_s_ = t_s; }
  // Stores the state at time() for delayed measurements.
  void Record(const Eigen::Vector3d& p_N_m, const Eigen::Vector3d& v_N_mps) { buffer_.Push(t_s_, p_N_m, v_N_mps); }
  // The state at time t_s (interpolated; the current one at or after time()), counting a GPS sample
  // too old for the history as invalid.
  bool LookupForGps(double t_s, const Eigen::Vector3d& p_now, const Eigen::Vector3d& v_now, Eigen::Vector3d* p_then,
                    Eigen::Vector3d* v_then);
  bool Lookup(double t_s, const Eigen::Vector3d& p_now, const Eigen::Vector3d& v_now, Eigen::Vector3d* p_then,
              Eigen::Vector3d* v_then) const {
    return buffer_.Lookup(t_s, t_s_, p_now, v_now, p_then, v_then);
  }
  // A correction applied to the state is applied to its history too.
  void Shift(const Eigen::Vector3d& dp_N_m, const Eigen::Vector3d& dv_N_mps) { buffer_.Shift(dp_N_m, dv_N_mps); }

  // Health: each check that fails turns Health() into kNumerical naming the quantity, time and
  // (when given) the step; the filter then does nothing more.
  template <class V>
  bool CheckFinite(const V& v, const char* quantity, double t_s, const char* where = nullptr) {
    if (Finite(v)) return true;
    Fail("non-finite " + std::string(quantity) + " at t=" + Num(t_s) + " s" + Where(where));
    return false;
  }
  // Whether every coefficient is finite (allFinite()'s answer). A sum with an infinite or NaN term
  // is never finite, so a finite plain sum (one vectorised pass of additions) proves every
  // coefficient finite. Only when it is not (a non-finite term, or finite terms overflowing) the
  // exact test: x·0 is ±0 for a finite x and NaN for ±inf or NaN, so that sum is 0 exactly when
  // every coefficient is finite.
  template <class V>
  static bool Finite(const V& v) {
    return std::isfinite(PlainSum(v)) || (v.array() * 0.0).sum() == 0.0;
  }
  // |v_N| ≤ kMaxSpeed_mps (CheckSpeed without the failure).
  static bool SpeedOk(const Eigen::Vector3d& v_N_mps) { return v_N_mps.norm() <= kMaxSpeed_mps; }
  // |v_N| ≤ kMaxSpeed_mps, a speed no multirotor reaches.
  bool CheckSpeed(const Eigen::Vector3d& v_N_mps, double t_s, const char* where = nullptr);
  void Fail(const std::string& what) { health_ = Status::Numerical(name_ + ": " + what); }
  static std::string Num(double v);
  static std::string Where(const char* where) { return where ? std::string(" in ") + where : std::string(); }

  bool healthy() const { return health_.ok(); }
  const Status& health() const { return health_; }
  bool aligning() const { return aligning_; }
  double time() const { return t_s_; }
  const StaticAligner& aligner() const { return aligner_; }
  EstimatorStats& stats() { return stats_; }
  const EstimatorStats& stats() const { return stats_; }

  static constexpr double kMaxSpeed_mps = 1000.0;

 private:
  // Σ v in any order (only its finiteness is used). A large fixed-size matrix (the filters'
  // covariance) is summed in eight independent lanes, which the compiler packs into vector
  // additions: Eigen's sum() of 225 terms is one loop of dependent pairs, twice the instructions.
  template <class V>
  static double PlainSum(const V& v) {
    if constexpr (V::SizeAtCompileTime >= 64 && std::is_base_of_v<Eigen::PlainObjectBase<V>, V>) {  // contiguous
      constexpr int kN = V::SizeAtCompileTime;
      // The coefficients as an 8 × (kN/8) matrix whose column sum is accumulated packet-wise.
      const double* x = v.data();
      double total = Eigen::Map<const Eigen::Matrix<double, 8, kN / 8>>(x).rowwise().sum().sum();
      for (int i = kN - kN % 8; i < kN; ++i) total += x[i];
      return total;
    } else {
      return v.sum();
    }
  }

  // false: the sample went into the alignment, which the filter finishes when it is complete.
  bool FinishIfAligned(double align_time_s, Filter* filter) {
    if (aligner_.Ready(t_s_, align_time_s)) filter->OnAligned();
    return false;
  }

  std::string name_;
  double t_s_ = 0.0;       // time of the filter's state
  bool have_time_ = false;  // an IMU sample has set t_s_ since the reset
  bool aligning_ = false;
  StaticAligner aligner_;
  StateBuffer buffer_;
  EstimatorStats stats_;
  Status health_;
};

}  // namespace hexsim::nav::internal
