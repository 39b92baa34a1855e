// What a compass effect does to the heading (see verdict.h HeadingTurnOf).
#include <algorithm>
#include <cmath>

#include <Eigen/LU>

#include "hexsim/common/rotation.h"
#include "hexsim/gap/effects.h"
#include "stats.h"
#include "verdict.h"

namespace hexsim::gap::internal {

HeadingTurn HeadingTurnOf(const ChannelData& ch, const Analyzer& an, const Evaluated& e) {
  HeadingTurn h;
  constexpr int kBaselineField = 3;  // the baseline's columns 3..5 map a NED field into the sensor frame
  const Candidate* c = e.cand;
  const size_t n = ch.t.size();
  if (c == nullptr || !e.full.ok || c->p() == 0 || c->X.size() != n || ch.baseline.p() < kBaselineField + 3 ||
      ch.baseline.X.size() != n || !an.nested() || n == 0) {
    return h;
  }
  const int p = c->p();
  // The Earth field the heading is taken from: the prior plus the baseline's fitted correction.
  const Vec3 B = ch.field_N_uT + an.baseline().full.beta.segment(kBaselineField, 3);
  const double bh2 = B.x() * B.x() + B.y() * B.y();
  if (!(bh2 > 0)) return h;
  // The heading turn of a small NED field δ: (B_N·δ_E − B_E·δ_N)/|B_h|², δ = (M·R)⁻¹·δ_S.
  const Eigen::RowVector3d turn(-B.y() / bh2, B.x() / bh2, 0.0);
  // A field the motor current or the throttle drives turns the heading from the state the compass was
  // calibrated in, motors off (ArduPilot's and PX4's compass calibrations are done disarmed): its whole
  // field counts, its flight mean too (the baseline's offset holds that mean on top of the
  // calibration's own). Any other effect: its variation about the flight mean (a constant part is
  // the offset's, and it has no state of its own to be measured from).
  const EffectKind kind = Info(c->id).kind;
  const bool from_motors_off = kind == EffectKind::kCurrentField || kind == EffectKind::kThrottleField;
  Mat3X mean_x = Mat3X::Zero(3, p);
  if (!from_motors_off) {
    for (const Mat3X& x : c->X) mean_x += x / static_cast<double>(n);
  }
  // Per sample the row a_k = turnᵀ·(M·R)_k⁻¹·(X_k − X̄): δψ_k = a_k·β. H = mean of a_kᵀ·a_k.
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(p, p);
  for (size_t k = 0; k < n; ++k) {
    const Eigen::Matrix3d MR = ch.baseline.X[k].middleCols(kBaselineField, 3);
    const Eigen::FullPivLU<Eigen::Matrix3d> lu(MR);
    if (!lu.isInvertible()) return h;
    const Eigen::RowVectorXd a = (turn * lu.inverse()) * (c->X[k] - mean_x);
    H.noalias() += a.transpose() * a / static_cast<double>(n);
  }
  const Eigen::VectorXd beta = e.full.beta.segment(e.off, p);
  const double ms = beta.dot(H * beta);
  if (!(ms > 0)) return h;
  const double rms = std::sqrt(ms);
  // Its 95 % interval's low end: the delta method on the block jackknife's covariance (the
  // reported intervals' method), t over G − 1 blocks.
  const Eigen::MatrixXd V = JackknifeCov(e).block(e.off, e.off, p, p);
  const Eigen::VectorXd grad = H * beta / rms;
  const double sd = std::sqrt(std::max(0.0, grad.dot(V * grad)));
  const double t975 = StudentT975(static_cast<double>(an.G() - 1));
  h.deg = kRadToDeg * rms;
  h.lo_deg = kRadToDeg * std::max(0.0, rms - t975 * sd);
  return h;
}

bool TurnsHeading(const HeadingTurn& h, const DiagnoseOptions& o) {
  return o.material_heading_deg > 0 && h.lo_deg >= o.material_heading_deg;
}

}  // namespace hexsim::gap::internal
