// The paper's ground sampling rig: the vehicle clamped on a non-magnetic turntable, every motor at
// one control amount (props turning, body not flying), turned through full circles in the X-Y, Y-Z
// and X-Z planes while the compasses are sampled. Uses the same powertrain and sensor models as a
// flight, so the currents, their field at each compass, noise and lag are the flight's.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "hexsim/common/status.h"
#include "hexsim/magnetics/compensator.h"
#include "hexsim/sim/world.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::sim {

struct TurntableOptions {
  std::vector<std::string> planes = {"xy", "yz", "xz"};
  std::vector<double> control_u = {0.0, 200.0, 300.0};  // paper's units, 0…1000
  double step_deg = 5.0;           // table step between samples
  double settle_s = 1.5;           // motors settle at each control amount before the turn
  double initial_yaw_deg = 0.0;    // heading of the vehicle's nose at table angle 0
  double soc = -1.0;               // battery state of charge; < 0: the vehicle's initial one
  uint64_t seed = 1;
  double physics_dt_s = 0.001;
  Status IsValid() const;
};

struct TurntableRow {
  std::string plane;
  double control_u = 0.0;
  double current_A = 0.0;    // measured battery current
  double angle_deg = 0.0;    // right-handed about the plane's normal (z for xy, x for yz, y for xz)
  Eigen::Quaterniond q_NB = Eigen::Quaterniond::Identity();  // true attitude from the rig
  std::vector<Eigen::Vector3d> mag_B_uT;                      // one per compass
  Eigen::Vector3d earth_B_uT = Eigen::Vector3d::Zero();       // true Earth field in body (evaluation only)
};

// Attitude of the rig at a table angle.
Eigen::Quaterniond TurntableAttitude(const std::string& plane, double angle_deg, double initial_yaw_deg);

Result<std::vector<TurntableRow>> RunTurntable(const vehicle::VehicleParams& vehicle_params, const WorldParams& world,
                                               const TurntableOptions& options);

// samples.csv (CONTRACTS): plane, control_u, current_A, angle_deg, q_w..q_z, mag_x_uT.. (mag2_.. for
// further compasses), earth_x_uT, earth_y_uT, earth_z_uT.
std::string TurntableCsv(const std::vector<TurntableRow>& rows);

// The samples of compass `index` as calibration input.
std::vector<magnetics::MagSample> ToMagSamples(const std::vector<TurntableRow>& rows, size_t index);

}  // namespace hexsim::sim
