#include "hexsim/magnetics/current_field.h"

#include <cmath>
#include <string>

#include <Eigen/Geometry>

namespace hexsim::magnetics {
namespace {

// Effective current for the field: sign(I)·|I|^exponent (exactly I when exponent == 1).
double Effective(double current_A, double exponent) {
  if (exponent == 1.0) return current_A;
  return std::copysign(std::pow(std::abs(current_A), exponent), current_A);
}

double SourceCurrent(CurrentSource source, int motor_index, const Currents& c) {
  if (source == CurrentSource::kBattery) return c.battery_A;
  HEXSIM_CHECK(motor_index >= 0 && static_cast<size_t>(motor_index) < c.motor_A.size());
  return c.motor_A[static_cast<size_t>(motor_index)];
}

bool Finite(const Eigen::Vector3d& v) { return v.allFinite(); }

}  // namespace

Eigen::Vector3d SegmentField_uT(const Eigen::Vector3d& a_m, const Eigen::Vector3d& b_m, double current_A,
                                const Eigen::Vector3d& p_m) {
  // B = μ0 I/(4π) · (r1 × r2)(|r1| + |r2|) / (|r1||r2|(|r1||r2| + r1·r2)), r1 = p − a, r2 = p − b.
  const Eigen::Vector3d r1 = p_m - a_m;
  const Eigen::Vector3d r2 = p_m - b_m;
  // r1 × r2 = (b − a) × r1, computed without the cancellation of two long, nearly antiparallel vectors.
  const Eigen::Vector3d cross = (b_m - a_m).cross(r1);
  const double cross2 = cross.squaredNorm();
  // On the segment's line: zero outside the segment (exact), singular on it (a compass never sits there).
  if (!(cross2 > 0.0)) return Eigen::Vector3d::Zero();
  const double n1 = r1.norm();
  const double n2 = r2.norm();
  const double dot = r1.dot(r2);
  // |r1||r2| + r1·r2 = |r1 × r2|² / (|r1||r2| − r1·r2): the second form avoids cancellation when the
  // point sees the segment under a wide angle (r1·r2 < 0), e.g. near the middle of a long wire.
  const double n1n2 = n1 * n2;
  const double sum = (dot >= 0.0) ? n1n2 + dot : cross2 / (n1n2 - dot);
  return (kMu0Over4Pi_uTmpA * current_A * (n1 + n2) / (n1n2 * sum)) * cross;
}

Eigen::Vector3d DipoleField_uT(const Eigen::Vector3d& moment_Am2, const Eigen::Vector3d& dipole_p_m,
                               const Eigen::Vector3d& p_m) {
  // B = μ0/(4π)·(3(m·r̂)r̂ − m)/|r|³
  const Eigen::Vector3d r = p_m - dipole_p_m;
  const double d = r.norm();
  if (!(d > 0.0)) return Eigen::Vector3d::Zero();
  const Eigen::Vector3d r_hat = r / d;
  return (kMu0Over4Pi_uTmpA / (d * d * d)) * (3.0 * moment_Am2.dot(r_hat) * r_hat - moment_Am2);
}

Status ValidateCurrentFieldParams(const CurrentFieldParams& p, int motor_count) {
  for (size_t i = 0; i < p.segments.size(); ++i) {
    const WireSegment& s = p.segments[i];
    const std::string field = "segments[" + std::to_string(i) + "]" + (s.name.empty() ? "" : " (" + s.name + ")");
    if (!Finite(s.a_B_m) || !Finite(s.b_B_m)) return Status::BadInput(field + ": end points must be finite");
    if ((s.b_B_m - s.a_B_m).norm() <= 0.0) return Status::BadInput(field + ": zero-length segment");
    if (!std::isfinite(s.share)) return Status::BadInput(field + ": share must be finite");
    if (s.source == CurrentSource::kMotor && (s.motor_index < 0 || s.motor_index >= motor_count)) {
      return Status::BadInput(field + ": motor_index " + std::to_string(s.motor_index) + " outside [0, " +
                              std::to_string(motor_count) + ")");
    }
  }
  for (size_t i = 0; i < p.dipoles.size(); ++i) {
    const MotorDipole& d = p.dipoles[i];
    const std::string field = "dipoles[" + std::to_string(i) + "]";
    if (d.motor_index < 0 || d.motor_index >= motor_count) {
      return Status::BadInput(field + ": motor_index " + std::to_string(d.motor_index) + " outside [0, " +
                              std::to_string(motor_count) + ")");
    }
    if (!Finite(d.p_B_m) || !Finite(d.moment_per_A_Am2)) return Status::BadInput(field + ": must be finite");
  }
  if (!std::isfinite(p.lag_tau_s) || p.lag_tau_s < 0.0) return Status::BadInput("lag_tau_s: must be >= 0");
  if (!std::isfinite(p.exponent) || p.exponent <= 0.0) return Status::BadInput("exponent: must be > 0");
  return Status::Ok();
}

Eigen::Vector3d CurrentDrivenField_uT(const CurrentFieldParams& p, const Eigen::Vector3d& sensor_p_B_m,
                                      const Currents& currents) {
  Eigen::Vector3d B_uT = Eigen::Vector3d::Zero();
  for (const WireSegment& s : p.segments) {
    const double I_A = s.share * SourceCurrent(s.source, s.motor_index, currents);
    B_uT += SegmentField_uT(s.a_B_m, s.b_B_m, Effective(I_A, p.exponent), sensor_p_B_m);
  }
  for (const MotorDipole& d : p.dipoles) {
    const double I_A = SourceCurrent(CurrentSource::kMotor, d.motor_index, currents);
    B_uT += DipoleField_uT(Effective(I_A, p.exponent) * d.moment_per_A_Am2, d.p_B_m, sensor_p_B_m);
  }
  return B_uT;
}

FixedPointCurrentField::FixedPointCurrentField(const CurrentFieldParams& p, const Eigen::Vector3d& sensor_p_B_m)
    : exponent_(p.exponent) {
  terms_.reserve(p.segments.size() + p.dipoles.size());
  for (const WireSegment& s : p.segments) {
    terms_.push_back({SegmentField_uT(s.a_B_m, s.b_B_m, 1.0, sensor_p_B_m), s.source, s.motor_index, s.share});
  }
  for (const MotorDipole& d : p.dipoles) {
    terms_.push_back({DipoleField_uT(d.moment_per_A_Am2, d.p_B_m, sensor_p_B_m), CurrentSource::kMotor, d.motor_index, 1.0});
  }
}

Eigen::Vector3d FixedPointCurrentField::operator()(const Currents& currents) const {
  Eigen::Vector3d B_uT = Eigen::Vector3d::Zero();
  for (const Term& t : terms_) {
    B_uT += Effective(t.share * SourceCurrent(t.source, t.motor_index, currents), exponent_) * t.B_per_A_uT;
  }
  return B_uT;
}

const Currents& StepCurrentLag(const CurrentFieldParams& p, const Currents& in, double dt_s,
                               CurrentLagState* state) {
  HEXSIM_CHECK(state != nullptr);
  HEXSIM_CHECK(dt_s >= 0.0);
  Currents& y = state->filtered;
  const bool resized = y.motor_A.size() != in.motor_A.size();
  if (!state->initialised || resized || p.lag_tau_s <= 0.0) {
    // Steady state on the first call (or when the motor set changes); τ = 0 passes through.
    y.battery_A = in.battery_A;
    y.motor_A.assign(in.motor_A.begin(), in.motor_A.end());  // no allocation once capacity suffices
    state->initialised = true;
    return y;
  }
  // y ← α·y + (1 − α)·u, α = e^(−dt/τ)
  const double alpha = std::exp(-dt_s / p.lag_tau_s);
  y.battery_A = alpha * y.battery_A + (1.0 - alpha) * in.battery_A;
  for (size_t i = 0; i < y.motor_A.size(); ++i) y.motor_A[i] = alpha * y.motor_A[i] + (1.0 - alpha) * in.motor_A[i];
  return y;
}

}  // namespace hexsim::magnetics
