// Magnetic field of the vehicle's own currents at a compass: DC wiring as straight segments
// (exact Biot–Savart), each motor as a point dipole whose moment is proportional to its DC current.
//
// Conventions: all positions in the body frame B (FRD), metres; fields in µT.
// A WireSegment carries its current from a_B_m to b_B_m (conventional current, a→b), so a positive
// current along +x produces, at a point on +y, a field along +z (right-hand rule: B ∝ dl × r).
// A negative current flows b→a. The return conductor of a lead pair is a separate segment.
// Three-phase motor leads are taken as cancelling and are not modelled (see CONTRACTS.md).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexsim/common/status.h"

namespace hexsim::magnetics {

// μ0/(4π) in µT·m/A.
inline constexpr double kMu0Over4Pi_uTmpA = 0.1;

// Exact Biot–Savart field of a finite straight segment a→b carrying current_A, at point p (all body
// frame, metres). µT. B = μ0 I/(4π) · (r1 × r2)(|r1| + |r2|) / (|r1||r2|(|r1||r2| + r1·r2)),
// r1 = p − a, r2 = p − b. On the segment's line outside the segment the field is exactly zero; on the
// segment itself it is singular and zero is returned (a compass never sits on a wire).
Eigen::Vector3d SegmentField_uT(const Eigen::Vector3d& a_m, const Eigen::Vector3d& b_m, double current_A,
                                const Eigen::Vector3d& p_m);

// Point dipole field: B = μ0/(4π)·(3(m·r̂)r̂ − m)/|r|³, r = p − dipole_p. moment in A·m². µT.
// Zero at the dipole's own position.
Eigen::Vector3d DipoleField_uT(const Eigen::Vector3d& moment_Am2, const Eigen::Vector3d& dipole_p_m,
                               const Eigen::Vector3d& p_m);

// kBattery: total battery current; kMotor: motor `motor_index`'s DC (battery-side) current.
enum class CurrentSource { kBattery, kMotor };

struct WireSegment {
  Eigen::Vector3d a_B_m = Eigen::Vector3d::Zero();  // current enters here ...
  Eigen::Vector3d b_B_m = Eigen::Vector3d::Zero();  // ... and leaves here
  CurrentSource source = CurrentSource::kBattery;
  int motor_index = -1;  // 0-based, only for kMotor
  double share = 1.0;    // fraction of the source current in this segment (negative: flows b→a)
  std::string name;
};

struct MotorDipole {
  int motor_index = 0;                                         // 0-based
  Eigen::Vector3d p_B_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d moment_per_A_Am2 = Eigen::Vector3d::Zero();  // moment = moment_per_A · I_motor_dc
};

struct CurrentFieldParams {
  std::vector<WireSegment> segments;
  std::vector<MotorDipole> dipoles;
  double lag_tau_s = 0.0;  // first-order lag current→field, 0 = none
  double exponent = 1.0;   // field ∝ sign(I)·|I|^exponent; 1 = physical. Other values exist only to
                           // generate out-of-library test effects.
};

struct Currents {
  double battery_A = 0.0;
  std::vector<double> motor_A;  // DC current of each motor, 0-based
};

// Checks indices, finiteness and ranges: every kMotor segment and dipole names a motor in
// [0, motor_count), lag_tau_s >= 0, exponent > 0. kBadInput naming the offending field.
Status ValidateCurrentFieldParams(const CurrentFieldParams& p, int motor_count);

// Field at the sensor position from the given currents (no lag). µT, body frame. Allocation-free.
// A motor index outside currents.motor_A is a broken invariant (validate the params first).
Eigen::Vector3d CurrentDrivenField_uT(const CurrentFieldParams& p, const Eigen::Vector3d& sensor_p_B_m,
                                      const Currents& currents);

// CurrentDrivenField_uT at one fixed point (a compass' position in B), its geometry folded once:
// every segment's and dipole's field is linear in its effective current, so
//   B = Σ_segments g_s·Eff(share_s·I_s) + Σ_dipoles g_d·Eff(I_d),
// g = the field per ampere at the point. The same law; the products are grouped differently, so the
// result differs from CurrentDrivenField_uT's by rounding only (relative ~1e-16). For the sensor
// loop, where the compass samples at its own rate with the geometry fixed.
class FixedPointCurrentField {
 public:
  FixedPointCurrentField() = default;
  FixedPointCurrentField(const CurrentFieldParams& p, const Eigen::Vector3d& sensor_p_B_m);
  Eigen::Vector3d operator()(const Currents& currents) const;

 private:
  struct Term {
    Eigen::Vector3d B_per_A_uT = Eigen::Vector3d::Zero();
    CurrentSource source = CurrentSource::kBattery;
    int motor_index = -1;
    double share = 1.0;
  };
  std::vector<Term> terms_;
  double exponent_ = 1.0;
};

// Lag state: first-order filter of the currents with lag_tau_s, exact discretisation for an input
// held over the step: y ← e^(−dt/τ)·y + (1 − e^(−dt/τ))·u. The first call (not initialised) starts
// in steady state (y = u). τ = 0 passes the input through.
struct CurrentLagState {
  Currents filtered;
  bool initialised = false;
};

// Advances the lag by dt_s (>= 0) with input `in` and returns the filtered currents. Allocation-free
// once the motor count is stable.
const Currents& StepCurrentLag(const CurrentFieldParams& p, const Currents& in, double dt_s,
                               CurrentLagState* state);

}  // namespace hexsim::magnetics
