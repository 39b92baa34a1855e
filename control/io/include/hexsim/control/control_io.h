// hexsim::control_io: the `control:` YAML map <-> ControllerParams and the mission YAML -> Mission,
// on yaml-cpp (hexsim::common_io's YamlReader); the core hexsim::control needs only the standard
// library and Eigen.
#pragma once

#include <string>

#include <yaml-cpp/yaml.h>

#include "hexsim/common/status.h"
#include "hexsim/common/yaml_reader.h"
#include "hexsim/control/controller.h"
#include "hexsim/control/mission.h"

namespace hexsim::control {

// Reads a `control:` map (the reader is on that map): pos {kp, z_kp}, vel {xy, z} {kp, ki, kd,
// output_limit, integrator_limit, d_filter_hz}, att {roll, pitch, yaw} {kp}, rate {roll, pitch, yaw}
// {kp, ki, kd, output_limit, integrator_limit, d_filter_hz}, limits {max_tilt_deg, max_speed_xy_mps,
// max_speed_up_mps, max_speed_down_mps, max_rate_rp_dps, max_yaw_rate_dps,
// min_thrust_fraction_of_weight}. Every key is optional (defaults above); unknown keys are errors.
Status ParseControllerParams(YamlReader& reader, ControllerParams* params);
// The full `control:` map with every key, so that a document can be completed with the defaults
// before `--set control.rate.roll.kp=...` overrides (ApplyOverride needs existing keys).
YAML::Node ControllerParamsToYaml(const ControllerParams& params);

// Parses a mission document; errors are "FILE:LINE: items[3].speed_mps: must be > 0 (got -2)".
Result<Mission> ParseMission(const YAML::Node& node, const std::string& file);

}  // namespace hexsim::control
