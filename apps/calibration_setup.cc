#include "calibration_setup.h"

#include <algorithm>
#include <filesystem>

#include "hexsim/common/paths.h"
#include "hexsim/common/yaml_reader.h"
#include "hexsim/magnetics/compensator.h"
#include "hexsim/sim/turntable.h"

namespace hexsim::app {

Result<std::shared_ptr<const magnetics::Compensator>> LearnOnTurntable(const std::string& method,
                                                                       const sim::RunSetup& setup) {
  sim::TurntableOptions opt;
  // The ground calibration is its own session: its noise is independent of the flight's.
  opt.seed = setup.options.seed * 1000003ULL + 17;
  auto rows = sim::RunTurntable(setup.vehicle, setup.world, opt);
  if (!rows.ok()) return rows.status();
  auto comp = magnetics::LearnCompensator(method, sim::ToMagSamples(*rows, 0), magnetics::LearnOptions{}, nullptr);
  if (!comp.ok()) return comp.status().WithContext("--calibration " + method);
  return std::shared_ptr<const magnetics::Compensator>(std::move(*comp));
}

Status AttachCalibration(const std::string& calibration, sim::RunSetup* setup) {
  setup->calibration_name = calibration;
  if (calibration == "none") {
    setup->compensator = nullptr;
    return Status::Ok();
  }
  const auto names = magnetics::CompensatorNames();
  if (std::find(names.begin(), names.end(), calibration) != names.end()) {
    auto comp = LearnOnTurntable(calibration, *setup);
    if (!comp.ok()) return comp.status();
    setup->compensator = *comp;
    return Status::Ok();
  }
  std::error_code ec;
  if (!std::filesystem::is_regular_file(calibration, ec)) {
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
    return Status::BadInput("--calibration: '" + calibration + "' is neither a file nor one of: " + list);
  }
  auto node = YamlReader::LoadFile(calibration);
  if (!node.ok()) return node.status();
  auto comp = magnetics::CompensatorFromYaml(*node, calibration);
  if (!comp.ok()) return comp.status();
  setup->compensator = std::shared_ptr<const magnetics::Compensator>(std::move(*comp));
  setup->calibration_name = FileStem(calibration);
  return Status::Ok();
}

}  // namespace hexsim::app
