// Shared by the gap tests that build a compass channel by hand (no flight): the offset baseline and
// the misalignment and current hard iron candidates as the replay builds them (replay_compass.cc).
#pragma once

#include <cmath>
#include <string>

#include "../../src/verdict.h"

namespace hexsim::gap::gaptest {

// A compass channel `name` in µT over an offset baseline; the caller fills t, y and the regressors.
inline internal::ChannelData OffsetBaselineCompass(const std::string& name) {
  internal::ChannelData ch;
  ch.name = name;
  ch.unit = "uT";
  ch.compass = true;
  ch.baseline = internal::MakeCandidate("offset", {"o_x", "o_y", "o_z"}, {1, 1, 1}, "uT");
  return ch;
}

// φ × h per sample: three small rotation angles, reported in degrees.
inline internal::Candidate MisalignmentCandidate() {
  return internal::MakeCandidate("misalignment", {"phi_x_deg", "phi_y_deg", "phi_z_deg"}, {180 / M_PI, 180 / M_PI, 180 / M_PI},
                                 "deg");
}

// d·I per sample: a field per ampere on each axis.
inline internal::Candidate CurrentHardIronCandidate() {
  return internal::MakeCandidate("current_hard_iron", {"d_x", "d_y", "d_z"}, {1, 1, 1}, "uT/A");
}

}  // namespace hexsim::gap::gaptest
