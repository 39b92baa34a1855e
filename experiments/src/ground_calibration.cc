#include "hexsim/experiments/ground_calibration.h"

#include <algorithm>
#include <filesystem>

#include "hexsim/common/paths.h"
#include "hexsim/common/yaml_reader.h"
#include "hexsim/magnetics/calib_io.h"
#include "hexsim/sim/turntable.h"

namespace hexsim::experiments {

uint64_t GroundSessionSeed(uint64_t flight_seed) { return flight_seed * 1000003ULL + 17; }

Result<std::vector<magnetics::MagSample>> RunGroundSession(const vehicle::VehicleParams& vehicle,
                                                           const sim::WorldParams& world, uint64_t flight_seed) {
  sim::TurntableOptions opt;
  opt.seed = GroundSessionSeed(flight_seed);
  auto rows = sim::RunTurntable(vehicle, world, opt);
  if (!rows.ok()) return rows.status();
  return sim::ToMagSamples(*rows, 0);
}

Result<std::vector<magnetics::MagSample>> RunTable1Turn(const vehicle::VehicleParams& vehicle,
                                                        const sim::WorldParams& world,
                                                        const std::vector<double>& control_u) {
  sim::TurntableOptions opt;
  opt.planes = {"xy"};
  opt.control_u = control_u;
  opt.seed = kTable1TurnSeed;
  auto rows = sim::RunTurntable(vehicle, world, opt);
  if (!rows.ok()) return rows.status();
  return sim::ToMagSamples(*rows, 0);
}

bool IsCalibrationMethod(const std::string& name) {
  if (name == "none") return true;
  const auto names = magnetics::CompensatorNames();
  return std::find(names.begin(), names.end(), name) != names.end();
}

namespace {

Result<GroundCalibration> FromFile(const std::string& calibration) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(calibration, ec)) {
    std::string list;
    for (const auto& n : magnetics::CompensatorNames()) list += (list.empty() ? "" : ", ") + n;
    return Status::BadInput("--calibration: '" + calibration + "' is neither a file nor one of: " + list);
  }
  auto node = YamlReader::LoadFile(calibration);
  if (!node.ok()) return node.status();
  auto comp = magnetics::CompensatorFromYaml(*node, calibration);
  if (!comp.ok()) return comp.status();
  return GroundCalibration{calibration, FileStem(calibration), std::shared_ptr<const magnetics::Compensator>(std::move(*comp))};
}

}  // namespace

Result<GroundCalibration> MakeCalibration(const std::string& calibration,
                                          const std::vector<magnetics::MagSample>& ground) {
  if (calibration == "none") return GroundCalibration{"none", "none", nullptr};
  if (!IsCalibrationMethod(calibration)) return FromFile(calibration);
  auto comp = magnetics::LearnCompensator(calibration, ground, magnetics::LearnOptions{}, nullptr);
  if (!comp.ok()) return comp.status().WithContext("--calibration " + calibration);
  return GroundCalibration{calibration, calibration, std::shared_ptr<const magnetics::Compensator>(std::move(*comp))};
}

Result<GroundCalibration> MakeCalibration(const std::string& calibration, const sim::RunSetup& setup) {
  if (!IsCalibrationMethod(calibration) || calibration == "none") {
    return MakeCalibration(calibration, std::vector<magnetics::MagSample>{});
  }
  auto ground = RunGroundSession(setup.vehicle, setup.world, setup.options.seed);
  if (!ground.ok()) return ground.status();
  return MakeCalibration(calibration, *ground);
}

Status AttachCalibration(const std::string& calibration, sim::RunSetup* setup) {
  auto cal = MakeCalibration(calibration, *setup);
  if (!cal.ok()) return cal.status();
  setup->compensator = cal->compensator;
  setup->calibration_name = cal->name;
  return Status::Ok();
}

}  // namespace hexsim::experiments
