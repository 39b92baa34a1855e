#include "hexsim/experiments/point_runner.h"

#include "hexsim/common/atomic_file.h"
#include "hexsim/experiments/ground_calibration.h"
#include "hexsim/logs/flight_log.h"

namespace hexsim::experiments {

Result<sim::RunOutput> FlyPoint(sim::RunSetup setup, const std::string& calibration) {
  HEXSIM_RETURN_IF_ERROR(AttachCalibration(calibration, &setup));
  return sim::RunMission(setup);
}

Result<sim::RunOutput> FlyPoint(const batch::RunPoint& point, batch::SetupCache* cache) {
  auto setup = cache->Get(point);
  if (!setup.ok()) return setup.status();
  return FlyPoint(std::move(*setup), point.calibration);
}

Status WriteRunLog(const sim::RunOutput& output, const std::string& dir) {
  return logs::WriteFlightLog(output.log, dir + "/log.csv");
}

Status WriteRunSummary(const sim::RunOutput& output, const std::string& dir) {
  return WriteFileAtomic(dir + "/summary.json", sim::ToJson(output.summary).dump(2) + "\n");
}

}  // namespace hexsim::experiments
