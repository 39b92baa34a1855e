// The effect registry (see effects.h).
#include "hexsim/gap/effects.h"

#include <cstddef>

namespace hexsim::gap {

const std::vector<EffectInfo>& Effects() {
  using K = EffectKind;
  static const std::vector<EffectInfo> kEffects = {
      {Effect::kNone, "", K::kNone, "", "", ""},
      {Effect::kCurrentHardIron, "current_hard_iron", K::kCurrentField, "uT/A", "current_hard_iron",
       "battery current I: d·I per axis", true},
      {Effect::kPerMotorCurrentHardIron, "per_motor_current_hard_iron", K::kCurrentField, "uT", "per_motor_current_hard_iron",
       "each motor's field in proportion to its output to the power 0.65 (ArduPilot's COMPASS_PMOT): c_m per motor and "
       "axis, the field at full output",
       true},
      {Effect::kCurrentLag, "current_lag", K::kCurrentField, "s", "current_lag",
       "the current low-passed with time constant tau (grid), to a power 1..2: d per axis", true},
      {Effect::kThrottleHardIron, "throttle_hard_iron", K::kThrottleField, "uT/throttle", "throttle_hard_iron",
       "mean motor output u (0..1): d·u per axis", true},
      {Effect::kCurrentSoftIron, "current_soft_iron", K::kCurrentField, "1/A", "current_soft_iron",
       "I times the predicted field: a 3x3 matrix per ampere"},
      {Effect::kMisalignment, "misalignment", K::kSensor, "deg", "misalignment", "the predicted field's cross product: 3 angles"},
      {Effect::kScaleError, "scale_error", K::kSensor, "1", "scale_error", "the predicted field per axis: axis gains",
       false, true},
      {Effect::kCrossCoupling, "cross_coupling", K::kSensor, "1", "", "the predicted field's other axes: 3 symmetric terms"},
      {Effect::kTemperatureDrift, "temperature_drift", K::kSensor, "uT/C", "temperature_drift",
       "the logged temperature's change: per axis"},
      {Effect::kLatency, "latency", K::kTiming, "s", "latency", "the prediction's time derivative"},
      // The reference's heading error δψ = c·I turns the predicted Earth field about down: the
      // compass reads M·R_NBᵀ·(ẑ × B_N)·δψ more than predicted (c in deg/A, signed: the reference's
      // heading minus the true one, per ampere; physical range in the plausibility table).
      {Effect::kReferenceYaw, "reference_yaw", K::kReference, "deg/A", "reference_yaw",
       "the Earth field turned about down by the reference's heading error c·I: M·R_NBᵀ·(z × B_N)·I", false, true},
      {Effect::kHardIronOffset, "hard_iron_offset", K::kNuisance, "uT", "hard_iron_offset", "a constant per axis"},
      {Effect::kLocalAnomaly, "local_anomaly", K::kNuisance, "uT", "local_anomaly",
       "a constant field in NED across the Earth field's direction"},
      {Effect::kFieldScale, "field_scale", K::kNuisance, "1", "field_scale",
       "the Earth field's magnitude (reported as scale - 1; the range row holds the ratio)", false, true},
      {Effect::kBias, "bias", K::kSensor, "", "", "a constant per axis"},
      {Effect::kMotorTimeConstant, "motor_time_constant", K::kDynamics, "s", "motor_time_constant", "thrust's rate of change"},
      {Effect::kThrustScale, "thrust_scale", K::kDynamics, "1", "thrust_scale", "the modelled thrust"},
      {Effect::kRotorDrag, "rotor_drag", K::kDynamics, "N/(rad/s*m/s)", "rotor_drag", "rotor speeds times airspeed"},
      {Effect::kBatterySag, "battery_sag", K::kDynamics, "ohm", "battery_sag", "the current through an extra resistance"},
      {Effect::kGroundEffect, "ground_effect", K::kDynamics, "m", "ground_effect", "thrust against height over the ground"},
      {Effect::kWind, "wind", K::kDynamics, "m/s", "wind", "a constant horizontal wind through the drag"},
  };
  return kEffects;
}

const EffectInfo& Info(Effect e) {
  const auto& all = Effects();
  const auto i = static_cast<size_t>(e);
  return i < all.size() ? all[i] : all.front();
}

Effect EffectFromName(std::string_view name) {
  if (name.empty()) return Effect::kNone;
  for (const EffectInfo& e : Effects()) {
    if (name == e.name) return e.id;
  }
  return Effect::kNone;
}

bool DrivenByCurrent(Effect e) {
  const EffectKind k = Info(e).kind;
  return k == EffectKind::kCurrentField || k == EffectKind::kThrottleField;
}

}  // namespace hexsim::gap
