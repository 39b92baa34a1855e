// The concrete compensators behind compensator.h, for code that builds one from known parameters.
#pragma once

#include <string>

#include "hexsim/magnetics/compensator.h"

namespace hexsim::magnetics {

// K⁻¹(H − β). name(): "traditional" (or "none" with K = I, β = 0).
class EllipsoidCompensator : public Compensator {
 public:
  EllipsoidCompensator(std::string method, const Eigen::Matrix3d& soft_iron, const Eigen::Vector3d& hard_iron_uT);
  std::string name() const override { return method_; }
  Eigen::Vector3d Correct(const Eigen::Vector3d& raw_B_uT, const CompensatorInput& in) const override;
  const Eigen::Matrix3d& soft_iron() const { return K_; }
  const Eigen::Vector3d& hard_iron_uT() const { return beta_uT_; }

 private:
  std::string method_;
  Eigen::Matrix3d K_;
  Eigen::Matrix3d K_inv_;
  Eigen::Vector3d beta_uT_;
};

enum class LineIndex { kControl, kCurrent };

// K⁻¹(H − β(x)), β(x) = line.At(x), x = control_u ("adaptive") or current_A ("adaptive-current").
class LineCompensator : public Compensator {
 public:
  LineCompensator(std::string method, const Eigen::Matrix3d& soft_iron, HardIronLine line, LineIndex index);
  std::string name() const override { return method_; }
  Eigen::Vector3d Correct(const Eigen::Vector3d& raw_B_uT, const CompensatorInput& in) const override;
  const Eigen::Matrix3d& soft_iron() const { return K_; }
  const HardIronLine& line() const { return line_; }
  LineIndex index() const { return index_; }

 private:
  std::string method_;
  Eigen::Matrix3d K_;
  Eigen::Matrix3d K_inv_;
  HardIronLine line_;
  LineIndex index_;
};

// Where the per-ampere vector c is applied (see compensator.h).
enum class CurrentFrame {
  kCorrected,  // "compassmot": K⁻¹(H − β) − c·(I − I0)
  kRaw,        // "px4-ls":     K⁻¹(H − β − c·(I − I0))
};

class CurrentSlopeCompensator : public Compensator {
 public:
  CurrentSlopeCompensator(std::string method, const Eigen::Matrix3d& soft_iron, const Eigen::Vector3d& hard_iron_uT,
                          const Eigen::Vector3d& c_uT_per_A, double current_ref_A, CurrentFrame frame);
  std::string name() const override { return method_; }
  Eigen::Vector3d Correct(const Eigen::Vector3d& raw_B_uT, const CompensatorInput& in) const override;
  const Eigen::Matrix3d& soft_iron() const { return K_; }
  const Eigen::Vector3d& hard_iron_uT() const { return beta_uT_; }
  const Eigen::Vector3d& c_uT_per_A() const { return c_uT_per_A_; }
  double current_ref_A() const { return current_ref_A_; }
  CurrentFrame frame() const { return frame_; }

 private:
  std::string method_;
  Eigen::Matrix3d K_;
  Eigen::Matrix3d K_inv_;
  Eigen::Vector3d beta_uT_;
  Eigen::Vector3d c_uT_per_A_;
  double current_ref_A_;
  CurrentFrame frame_;
};

}  // namespace hexsim::magnetics
