// Serialisation for calibration: samples.csv text ↔ MagSample, compensator → calib.yaml text,
// fits and gates → JSON. Strings only: the app reads and writes the files.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "hexsim/common/status.h"
#include "hexsim/magnetics/compensator.h"
#include "hexsim/magnetics/ellipsoid_fit.h"

namespace hexsim::magnetics {

// samples.csv (CONTRACTS): plane, control_u, current_A, angle_deg, q_w, q_x, q_y, q_z,
// mag_x_uT, mag_y_uT, mag_z_uT, [earth_x_uT, earth_y_uT, earth_z_uT], further columns ignored.
// `mag_prefix` picks the compass ("mag", "mag2", ...). Missing required columns, bad numbers or
// ragged rows are BadInput "FILE:LINE: COLUMN: what". Without earth_* columns earth_B_uT stays 0.
Result<std::vector<MagSample>> ParseSamplesCsv(const std::string& text, const std::string& file,
                                               const std::string& mag_prefix = "mag");
// The same columns (with earth_*), full double precision.
std::string SamplesToCsv(const std::vector<MagSample>& samples);

// calib.yaml text for a compensator.
std::string CompensatorToYamlText(const Compensator& compensator);

nlohmann::json GateToJson(const FitGate& gate);
nlohmann::json EllipsoidFitToJson(const EllipsoidFit& fit);
// Maps → objects, sequences → arrays, numeric scalars → numbers, other scalars → strings.
nlohmann::json YamlToJson(const YAML::Node& node);

}  // namespace hexsim::magnetics
