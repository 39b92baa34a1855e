// The effects the gap diagnosis can name: one typed registry. Each row gives the name gap.json
// writes, what kind of effect it is (which decides how the verdict, the parameter files and the
// report treat it), the unit of its one-number magnitude, the row of the plausibility table
// (common/plausibility) that holds its physical range, and the regressors that carry it in the
// replay. Code compares effects by Effect, never by name; the name is for gap.json and the text.
#pragma once

#include <string_view>
#include <vector>

namespace hexsim::gap {

enum class Effect {
  kNone,  // not a registered effect: the internal fits (baseline, library-free set), joint "a+b"
  // compass: fields that follow the motor current or the throttle (what COMPASS_MOT compensates)
  kCurrentHardIron,
  kPerMotorCurrentHardIron,
  kCurrentLag,
  kThrottleHardIron,
  kCurrentSoftIron,
  // compass: the sensor's own calibration and mounting
  kMisalignment,
  kScaleError,
  kCrossCoupling,
  kTemperatureDrift,
  // timing of a sensor against the attitude
  kLatency,
  // the attitude reference the compasses are predicted with (common to every compass of a log)
  kReferenceYaw,
  // compass nuisance baseline terms (named only beyond their normal range)
  kHardIronOffset,
  kLocalAnomaly,
  kFieldScale,
  // inertial sensors
  kBias,
  // vehicle dynamics (the dynamics channel)
  kMotorTimeConstant,
  kThrustScale,
  kRotorDrag,
  kBatterySag,
  kGroundEffect,
  kWind,
};

enum class EffectKind {
  kNone,
  kCurrentField,   // a field driven by the measured current (per ampere, per motor, lagged)
  kThrottleField,  // a field driven by the throttle (COMPASS_MOTCT 1), where the current is unusable
  kSensor,         // calibration and mounting of the sensor (static: does not follow the current)
  kTiming,         // a delay against the attitude
  kReference,      // an error of the attitude reference (the autopilot's estimate), not of the compass
  kNuisance,       // a term of the nuisance baseline
  kDynamics,       // the vehicle's dynamics
};

struct EffectInfo {
  Effect id = Effect::kNone;
  const char* name = "";        // gap.json "effect"
  EffectKind kind = EffectKind::kNone;
  const char* unit = "";        // unit of the magnitude ("" : the channel's own unit)
  const char* range_key = "";   // row of plausibility::PlausibilityTable() with its physical range
  const char* regressors = "";  // what carries it in the replay
  // A field added per ampere or per unit throttle: what COMPASS_MOT / CAL_MAGn_COMP compensate and
  // the in-flight model's absolute term measures (a current-driven soft iron is not).
  bool compensable = false;
  // The magnitude carries a sign (a scale's departure from one): its interval may cross zero and is
  // never clipped at zero. Every other magnitude is a norm or a lag (>= 0).
  bool signed_magnitude = false;
};

// Every registered effect, in the order of Effect.
const std::vector<EffectInfo>& Effects();
const EffectInfo& Info(Effect e);
// The registered effect of that name; Effect::kNone for any other name.
Effect EffectFromName(std::string_view name);
// A field the motor current causes (measured as current or, where unusable, as throttle): what
// COMPASS_MOT/CAL_MAGn_COMP compensate, and what the in-flight model's absolute term measures.
bool DrivenByCurrent(Effect e);

}  // namespace hexsim::gap
