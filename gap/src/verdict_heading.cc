// What a compass effect does to the heading (see verdict.h HeadingTurnOf).
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

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
  const EffectInfo& info = Info(c->id);
  const bool from_motors_off = info.kind == EffectKind::kCurrentField || info.kind == EffectKind::kThrottleField;
  // A field fixed in the body per ampere or per unit throttle (EffectInfo::compensable) turns the
  // heading by an amount that depends on the heading: its horizontal part across the Earth field's.
  // Its turn is taken over a full 360° turn of heading at each sample's current and tilt, as
  // CONTRACTS' heading error is (Table 1: a full turn in the level plane): the field is the
  // vehicle's, the headings a log happens to fly are not, and on a log flown on a few headings the
  // turn at those headings is the small difference of the field's two horizontal components (a
  // resolved field whose turn interval reaches 0). Rotating the vehicle by ψ about down rotates the
  // field's horizontal part v_h by ψ and leaves |v_h| and the Earth field as they are, so
  // mean over ψ of (turn·R_z(ψ)·v)² = |v_h|²/(2·|B_h|²). Any other effect's field depends on the
  // attitude itself (a soft iron, a misalignment, the reference's yaw): its turn over the flight flown.
  const bool full_turn = info.compensable;
  Mat3X mean_x = Mat3X::Zero(3, p);
  if (!from_motors_off) {
    for (const Mat3X& x : c->X) mean_x += x / static_cast<double>(n);
  }
  // Per sample the rows A_k = (M·R)_k⁻¹·(X_k − X̄), the field in NED per coefficient. Over the flight
  // δψ_k = turn·A_k·β, over a full turn mean δψ² = |(A_k·β)_h|²/(2·|B_h|²): H the mean of those
  // quadratic forms, the turn's mean square β·H·β.
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(p, p);
  for (size_t k = 0; k < n; ++k) {
    const Eigen::Matrix3d MR = ch.baseline.X[k].middleCols(kBaselineField, 3);
    const Eigen::FullPivLU<Eigen::Matrix3d> lu(MR);
    if (!lu.isInvertible()) return h;
    const Eigen::MatrixXd A = lu.inverse() * (c->X[k] - mean_x);
    if (full_turn) {
      const Eigen::MatrixXd Ah = A.topRows(2);
      H.noalias() += Ah.transpose() * Ah / (2.0 * bh2 * static_cast<double>(n));
    } else {
      const Eigen::RowVectorXd a = turn * A;
      H.noalias() += a.transpose() * a / static_cast<double>(n);
    }
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
  h.full_turn = full_turn;
  // An RMS is a norm: its low end is 0 wherever the field's coefficients' 95 % region holds zero
  // (their Wald test on the same covariance), as a reported norm's is (attribution.cc Describe).
  constexpr double kNormZeroLevel = 0.05;  // the 95 % of the reported intervals
  std::vector<int> all(static_cast<size_t>(p));
  for (int j = 0; j < p; ++j) all[static_cast<size_t>(j)] = j;
  if (WaldP(beta, V, all, static_cast<int>(e.blocks.size())) >= kNormZeroLevel) h.lo_deg = 0.0;
  return h;
}

std::string TurnBasis(const HeadingTurn& h, bool from_motors_off) {
  std::string s = h.full_turn ? "over a full turn of heading at the flight's current and tilt" : "over the flight";
  return from_motors_off ? s + ", from motors off" : s;
}

bool TurnsHeading(const HeadingTurn& h, const DiagnoseOptions& o) {
  return o.material_heading_deg > 0 && h.lo_deg >= o.material_heading_deg;
}

}  // namespace hexsim::gap::internal
