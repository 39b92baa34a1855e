// calibrate's physical ranges: rows of the one plausibility table (hexsim/common/plausibility.h,
// "Compass calibration"), read here so that the fit, its gate and the unit detection share them:
//   earth_field_norm 22–67 µT, raw_field_norm 11–167.5 µT (unit detection), compass_offset
//   0–180 µT, calibration_radius 15–100 µT, soft_iron_diagonal 0.8–1.2, soft_iron_off_diagonal
//   0–0.2, soft_iron_condition 1–2 (each row states why).
#pragma once

#include <limits>
#include <string_view>

#include "hexsim/common/plausibility.h"

namespace hexsim::magnetics {

// The row `name` (an unbounded range if the table lacks it: a test checks every row exists).
inline const plausibility::PhysicalRange& CalibrationRange(std::string_view name) {
  static const plausibility::PhysicalRange kUnbounded{"", "", -std::numeric_limits<double>::infinity(),
                                                     std::numeric_limits<double>::infinity(),
                                                     -std::numeric_limits<double>::infinity(),
                                                     std::numeric_limits<double>::infinity(), "no stated range"};
  const plausibility::PhysicalRange* r = plausibility::FindRange(name);
  return r != nullptr ? *r : kUnbounded;
}

}  // namespace hexsim::magnetics
