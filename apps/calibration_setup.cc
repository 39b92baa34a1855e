#include "calibration_setup.h"

#include <filesystem>

#include "hexsim/common/paths.h"
#include "hexsim/common/yaml_reader.h"
#include "hexsim/magnetics/compensator.h"

namespace hexsim::app {

Status AttachCalibration(const std::string& calibration, sim::RunSetup* setup) {
  setup->calibration_name = calibration;
  if (calibration == "none") {
    setup->compensator = nullptr;
    return Status::Ok();
  }
  std::error_code ec;
  if (std::filesystem::is_regular_file(calibration, ec) || calibration.find('/') != std::string::npos ||
      calibration.find(".yaml") != std::string::npos) {
    auto node = YamlReader::LoadFile(calibration);
    if (!node.ok()) return node.status();
    auto comp = magnetics::CompensatorFromYaml(*node, calibration);
    if (!comp.ok()) return comp.status();
    setup->compensator = std::shared_ptr<const magnetics::Compensator>(std::move(*comp));
    setup->calibration_name = FileStem(calibration);
    return Status::Ok();
  }
  return Status::BadInput("--calibration: '" + calibration + "' is not a calib.yaml and method calibration is not wired yet");
}

}  // namespace hexsim::app
