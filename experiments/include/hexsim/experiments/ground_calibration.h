// The ground calibration a flight uses (--calibration NAME|FILE): a compensator learnt on the
// simulated turntable from sensor data only, as a user would on the ground, or a calib.yaml written
// by `hexsim calibrate`. One place for the name lookup and for the ground session's seed, so the
// runs, Table 1 and the report all show the calibration that was flown.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hexsim/common/status.h"
#include "hexsim/magnetics/compensator.h"
#include "hexsim/sim/simulation.h"
#include "hexsim/sim/world.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::experiments {

// The ground session flown before a flight seeded s has its own seed, so that its sensor noise is
// independent of the flight's: s_ground = s·1000003 + 17.
uint64_t GroundSessionSeed(uint64_t flight_seed);
// Table 1 is evaluated on an independent level turn with this seed.
constexpr uint64_t kTable1TurnSeed = 7919;

// The ground session: every plane, control 0/200/300 (TurntableOptions' defaults), compass-1 samples.
Result<std::vector<magnetics::MagSample>> RunGroundSession(const vehicle::VehicleParams& vehicle,
                                                           const sim::WorldParams& world, uint64_t flight_seed);
// Table 1's level turn at the given control amounts, compass-1 samples.
Result<std::vector<magnetics::MagSample>> RunTable1Turn(const vehicle::VehicleParams& vehicle,
                                                        const sim::WorldParams& world,
                                                        const std::vector<double>& control_u);

// "none", a compensator method name (magnetics::CompensatorNames()), or else a file path.
bool IsCalibrationMethod(const std::string& name);

struct GroundCalibration {
  std::string requested;  // the --calibration argument as given (a method, "none" or a path)
  std::string name;       // as shown in summaries: the method, "none", or the calib.yaml's stem
  std::shared_ptr<const magnetics::Compensator> compensator;  // null for "none"
};

// `calibration` for a flight of `setup`: a method is learnt from `ground` (the session of
// GroundSessionSeed(setup's seed)); a file is read. BadInput for an unknown name or a bad file.
Result<GroundCalibration> MakeCalibration(const std::string& calibration,
                                          const std::vector<magnetics::MagSample>& ground);
// The same, running the ground session for setup.options.seed first when a method needs it.
Result<GroundCalibration> MakeCalibration(const std::string& calibration, const sim::RunSetup& setup);
// Sets setup->compensator and setup->calibration_name from MakeCalibration(calibration, *setup).
Status AttachCalibration(const std::string& calibration, sim::RunSetup* setup);

}  // namespace hexsim::experiments
