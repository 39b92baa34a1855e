// The configured compass model evaluated at the logged compass samples on a trial timing (private to
// gap/): shared by the replay (replay_compass.cc) and the latency scan (compass_timing.cc), so the
// scan's 41 trial latencies run the very model the replay fits, without building a channel each.
//
// A compass sample stamped t measured the field at t − L (L: latency against the attitude); the
// prediction uses the attitude at t − L and the current logged at t − L + S (S: the current shift).
// A sample is left out where the log has no rows around those times, where the attitude is not
// finite, or where the current (or a motor's share of it) jumps between the two rows around it.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "channels.h"
#include "hexsim/magnetics/compass_model.h"
#include "hexsim/magnetics/current_field.h"
#include "replay_util.h"

namespace hexsim::gap::internal {

struct CompassSample {
  double t;
  Vec3 m;
  int row;
};

// One sample located on the trial timing: the row interpolation, the currents the prediction uses.
struct LocatedSample {
  size_t i = 0;  // attitude row and weight: value = (1 − w)·v[i] + w·v[i + 1]
  double w = 0;
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();  // attitude at t − L (finite)
  magnetics::Currents currents;  // at t − L + S, split over the motors as at t − L
  double i_logged = 0;
};

class CompassSampler {
 public:
  CompassSampler(const logs::FlightLog& log, const vehicle::VehicleParams& v, size_t c, const LogInputs& in,
                 const Vec3& B_N_uT, bool calibrated_log, double share_exponent);

  // New compass samples (the autopilot's logged motor compensation undone where the log has it).
  const std::vector<CompassSample>& samples() const { return samples_; }
  bool undone_compensation() const { return undone_; }
  const magnetics::CompassErrorParams& error() const { return err_; }
  const magnetics::CurrentFieldParams& wiring() const { return wiring_; }
  // The configured wiring field at this compass (its geometry folded once).
  const magnetics::FixedPointCurrentField& field() const { return field_; }
  bool has_current() const { return in_.current != nullptr; }

  // Starts a pass over the samples (ascending time) at this timing: cursors and current lag reset.
  // reach_s: a sample is located only where the logged current has a finite value at t − L + reach_s
  // (the current-driven families' longest member shift: every member then has a current).
  void Begin(double latency_s, double current_shift_s, double reach_s);
  // Locates sample s on the pass's timing; false when it is left out. Allocation-free after the
  // first samples.
  bool Locate(const CompassSample& s, LocatedSample* out);
  // The prediction at a located sample (advances the configured current lag from the previously
  // predicted sample): the field before hard iron and the sensor gain M = R_SB·scale·K(I).
  struct Prediction {
    Vec3 pred;          // full predicted reading
    Vec3 h;             // pred without the hard iron
    Eigen::Matrix3d M;  // R_SB·scale·K(I_lagged)
  };
  Prediction Predict(const CompassSample& s, const LocatedSample& ls, const Eigen::Matrix3d& R_NB);

 private:
  double share_exponent_;  // I_i ∝ u_i^p (kShareExponent)
  const LogInputs& in_;
  const vehicle::VehicleParams& v_;
  const std::vector<double>& t_row_;
  magnetics::CurrentFieldParams wiring_;
  magnetics::CompassErrorParams err_;
  magnetics::FixedPointCurrentField field_;
  Vec3 B_N_uT_;
  std::vector<CompassSample> samples_;
  bool undone_ = false;
  // Per row: the motors' shares of the current (empty row: no finite outputs), and the largest
  // change of a share to the next row (infinite where one of the two rows has none).
  size_t n_motor_ = 0;
  std::vector<double> row_share_;  // n_motor_ per row
  std::vector<bool> row_share_ok_;
  std::vector<double> share_step_;
  std::vector<double> share_;  // the interpolated shares of the sample being located
  // The pass.
  double latency_s_ = 0, current_shift_s_ = 0, reach_s_ = 0;
  RowCursor cur_, cur_i_, cur_r_;
  magnetics::CurrentLagState lag_;
  bool first_ = true;
  double prev_t_ = 0;

  bool SharesAt(size_t i, double w);
};

}  // namespace hexsim::gap::internal
