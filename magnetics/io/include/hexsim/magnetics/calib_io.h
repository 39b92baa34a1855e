// Serialisation for calibration (hexsim::magnetics_io; the magnetics core has no YAML or JSON):
// samples.csv text ↔ MagSample, compensator ↔ calib.yaml, fits, gates and learn reports → JSON.
// Strings and nodes only: the app reads and writes the files.
#pragma once

#include <memory>
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

// calib.yaml content (schema, method and parameters) of a compensator of compensators.h, and its
// text; CompensatorFromYaml reads it back (errors name file:line:field).
YAML::Node CompensatorToYaml(const Compensator& compensator);
std::string CompensatorToYamlText(const Compensator& compensator);
Result<std::unique_ptr<Compensator>> CompensatorFromYaml(const YAML::Node& node, const std::string& file);

// hexsim.calib/1 of LearnCompensator's report: schema, method, accepted, gate, rms_residual_uT,
// coverage, fits, params, diagnostics, num_samples.
nlohmann::json LearnReportToJson(const LearnReport& report, const Compensator& compensator);

nlohmann::json GateToJson(const FitGate& gate);
nlohmann::json EllipsoidFitToJson(const EllipsoidFit& fit);
// Maps → objects, sequences → arrays, numeric scalars → numbers, other scalars → strings.
nlohmann::json YamlToJson(const YAML::Node& node);

}  // namespace hexsim::magnetics
