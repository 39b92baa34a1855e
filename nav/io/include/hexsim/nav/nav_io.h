// hexsim::nav_io: the `nav:` YAML map -> NavParams, on hexsim::common_io's YamlReader; the core
// hexsim::nav needs only the standard library and Eigen.
#pragma once

#include "hexsim/common/status.h"
#include "hexsim/common/yaml_reader.h"
#include "hexsim/nav/estimator.h"

namespace hexsim::nav {

// Reads the keys of a `nav:` map (all optional, same names as the NavParams fields; mag_mode is
// "heading" | "3axis"; earth_B_N_uT = [N, E, D]); unknown keys are rejected by the reader.
Status ParseNavParams(YamlReader& reader, NavParams* params);

}  // namespace hexsim::nav
