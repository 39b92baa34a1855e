// The concrete compensators (their calib.yaml form is magnetics_io's compensator_yaml.cc).
#include "hexsim/magnetics/compensator.h"

#include <cmath>
#include <utility>

#include <Eigen/LU>

#include "hexsim/magnetics/compensators.h"

namespace hexsim::magnetics {
namespace {

Eigen::Matrix3d CheckedInverse(const Eigen::Matrix3d& K) {
  Eigen::FullPivLU<Eigen::Matrix3d> lu(K);
  HEXSIM_CHECK(lu.isInvertible());
  return lu.inverse();
}

double IndexValue(LineIndex i, const CompensatorInput& in) {
  return i == LineIndex::kControl ? in.control_u : in.current_A;
}

}  // namespace

// ---- EllipsoidCompensator ----

EllipsoidCompensator::EllipsoidCompensator(std::string method, const Eigen::Matrix3d& soft_iron,
                                           const Eigen::Vector3d& hard_iron_uT)
    : method_(std::move(method)), K_(soft_iron), K_inv_(CheckedInverse(soft_iron)), beta_uT_(hard_iron_uT) {}

Eigen::Vector3d EllipsoidCompensator::Correct(const Eigen::Vector3d& raw_B_uT, const CompensatorInput&) const {
  return K_inv_ * (raw_B_uT - beta_uT_);
}

// ---- LineCompensator ----

LineCompensator::LineCompensator(std::string method, const Eigen::Matrix3d& soft_iron, HardIronLine line, LineIndex index)
    : method_(std::move(method)), K_(soft_iron), K_inv_(CheckedInverse(soft_iron)), line_(std::move(line)), index_(index) {}

Eigen::Vector3d LineCompensator::Correct(const Eigen::Vector3d& raw_B_uT, const CompensatorInput& in) const {
  return K_inv_ * (raw_B_uT - line_.At(IndexValue(index_, in)));
}

// ---- CurrentSlopeCompensator ----

CurrentSlopeCompensator::CurrentSlopeCompensator(std::string method, const Eigen::Matrix3d& soft_iron,
                                                 const Eigen::Vector3d& hard_iron_uT, const Eigen::Vector3d& c_uT_per_A,
                                                 double current_ref_A, CurrentFrame frame)
    : method_(std::move(method)),
      K_(soft_iron),
      K_inv_(CheckedInverse(soft_iron)),
      beta_uT_(hard_iron_uT),
      c_uT_per_A_(c_uT_per_A),
      current_ref_A_(current_ref_A),
      frame_(frame) {}

Eigen::Vector3d CurrentSlopeCompensator::Correct(const Eigen::Vector3d& raw_B_uT, const CompensatorInput& in) const {
  const Eigen::Vector3d motor_uT = c_uT_per_A_ * (in.current_A - current_ref_A_);
  if (frame_ == CurrentFrame::kCorrected) return K_inv_ * (raw_B_uT - beta_uT_) - motor_uT;
  return K_inv_ * (raw_B_uT - beta_uT_ - motor_uT);
}

// ---- factory ----

std::vector<std::string> CompensatorNames() {
  return {"none", "traditional", "adaptive", "adaptive-current", "compassmot", "px4-ls"};
}

std::unique_ptr<Compensator> MakeNoneCompensator() {
  return std::make_unique<EllipsoidCompensator>("none", Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
}

}  // namespace hexsim::magnetics
