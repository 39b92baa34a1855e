#include "hexsim/sim/turntable.h"

#include <cmath>

#include <fmt/format.h>

#include "hexsim/common/rotation.h"
#include "hexsim/magnetics/wmm.h"
#include "hexsim/vehicle/powertrain.h"
#include "hexsim/vehicle/sensors.h"

namespace hexsim::sim {

Status TurntableOptions::IsValid() const {
  if (planes.empty()) return Status::BadInput("--planes: at least one of xy, yz, xz");
  for (const auto& p : planes) {
    if (p != "xy" && p != "yz" && p != "xz") return Status::BadInput("--planes: '" + p + "' is not xy, yz or xz");
  }
  if (control_u.empty()) return Status::BadInput("--control: at least one control amount");
  for (double u : control_u) {
    if (!(u >= 0 && u <= 1000)) return Status::BadInput(fmt::format("--control: {} is outside 0…1000", u));
  }
  if (!(step_deg > 0 && step_deg <= 90)) return Status::BadInput(fmt::format("--step-deg: must be in (0, 90] (got {})", step_deg));
  if (!(settle_s >= 0 && settle_s < 60)) return Status::BadInput("settle_s: must be in [0, 60)");
  if (soc > 1.0) return Status::BadInput(fmt::format("--soc: must be <= 1 (got {})", soc));
  if (!(physics_dt_s > 0 && physics_dt_s <= 0.01)) return Status::BadInput("physics_dt_s: must be in (0, 0.01]");
  return Status::Ok();
}

Eigen::Quaterniond TurntableAttitude(const std::string& plane, double angle_deg, double initial_yaw_deg) {
  const double a = angle_deg * kDegToRad;
  const Eigen::Quaterniond base(Eigen::AngleAxisd(initial_yaw_deg * kDegToRad, Eigen::Vector3d::UnitZ()));
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  if (plane == "yz") axis = Eigen::Vector3d::UnitX();
  if (plane == "xz") axis = Eigen::Vector3d::UnitY();
  // The table turns the body about its own axis: R_NB = R_base · R_axis(a).
  return (base * Eigen::Quaterniond(Eigen::AngleAxisd(a, axis))).normalized();
}

Result<std::vector<TurntableRow>> RunTurntable(const vehicle::VehicleParams& vehicle_params, const WorldParams& world,
                                               const TurntableOptions& options) {
  HEXSIM_RETURN_IF_ERROR(options.IsValid());
  auto field = magnetics::EvaluateWmm({world.home_lat_deg, world.home_lon_deg, world.home_alt_m},
                                      world.date_decimal_year, world.allow_field_extrapolation);
  if (!field.ok()) return field.status();
  const Eigen::Vector3d B_N = field->B_N_uT + world.anomaly_N_uT;
  auto suite = vehicle::SensorSuite::Create(vehicle_params, options.seed);
  if (!suite.ok()) return suite.status();
  vehicle::SensorSuite sensors = std::move(*suite);

  vehicle::PowertrainState power = vehicle::InitialPowertrainState(vehicle_params);
  if (options.soc >= 0) power.soc = options.soc;
  const size_t n = vehicle_params.rotors.size();
  const double dt = options.physics_dt_s;
  double t = 0.0;
  std::vector<TurntableRow> rows;
  vehicle::PowertrainOutput pt = vehicle::EvaluatePowertrain(vehicle_params, power, std::vector<double>(n, 0.0));

  auto step = [&](const Eigen::Quaterniond& q, const std::vector<double>& commands) -> const vehicle::SensorReadings& {
    vehicle::SensorTruth truth;
    truth.t_s = t;
    truth.q_NB = q;
    truth.specific_force_B_mps2 = q.conjugate() * Eigen::Vector3d(0, 0, -kGravity_mps2);
    truth.B_earth_N_uT = B_N;
    truth.currents = pt.Currents();
    const vehicle::SensorReadings& rd = sensors.Step(truth);
    pt = vehicle::StepPowertrain(vehicle_params, commands, dt, &power);
    t += dt;
    return rd;
  };

  for (const std::string& plane : options.planes) {
    for (double u : options.control_u) {
      const std::vector<double> commands(n, u / 1000.0);
      const Eigen::Quaterniond q0 = TurntableAttitude(plane, 0.0, options.initial_yaw_deg);
      for (double s = 0; s < options.settle_s; s += dt) step(q0, commands);
      const int steps = static_cast<int>(std::lround(360.0 / options.step_deg));
      for (int k = 0; k < steps; ++k) {
        const double angle = k * options.step_deg;
        const Eigen::Quaterniond q = TurntableAttitude(plane, angle, options.initial_yaw_deg);
        // Wait for every compass to deliver a fresh sample taken at this table angle.
        std::vector<bool> fresh(vehicle_params.compasses.size(), false);
        TurntableRow row;
        row.plane = plane;
        row.control_u = u;
        row.angle_deg = angle;
        row.q_NB = q;
        row.mag_B_uT.resize(vehicle_params.compasses.size());
        row.earth_B_uT = q.conjugate() * B_N;
        double current_sum = 0.0;
        int current_n = 0;
        for (int guard = 0; guard < 100000; ++guard) {
          const vehicle::SensorReadings& rd = step(q, commands);
          current_sum += pt.battery_A;
          ++current_n;
          bool all = true;
          for (size_t c = 0; c < fresh.size(); ++c) {
            if (rd.mag_uT[c].fresh && !fresh[c]) {
              fresh[c] = true;
              row.mag_B_uT[c] = rd.mag_uT[c].value;
            }
            all = all && fresh[c];
          }
          if (all) break;
        }
        row.current_A = current_sum / current_n;
        rows.push_back(std::move(row));
      }
    }
  }
  return rows;
}

std::string TurntableCsv(const std::vector<TurntableRow>& rows) {
  const size_t ncomp = rows.empty() ? 0 : rows.front().mag_B_uT.size();
  std::string out = "plane,control_u,current_A,angle_deg,q_w,q_x,q_y,q_z";
  for (size_t c = 0; c < ncomp; ++c) {
    const std::string p = c == 0 ? "mag" : fmt::format("mag{}", c + 1);
    out += fmt::format(",{0}_x_uT,{0}_y_uT,{0}_z_uT", p);
  }
  out += ",earth_x_uT,earth_y_uT,earth_z_uT\n";
  for (const auto& r : rows) {
    out += fmt::format("{},{},{},{},{},{},{},{}", r.plane, r.control_u, r.current_A, r.angle_deg, r.q_NB.w(),
                       r.q_NB.x(), r.q_NB.y(), r.q_NB.z());
    for (const auto& m : r.mag_B_uT) out += fmt::format(",{},{},{}", m.x(), m.y(), m.z());
    out += fmt::format(",{},{},{}\n", r.earth_B_uT.x(), r.earth_B_uT.y(), r.earth_B_uT.z());
  }
  return out;
}

std::vector<magnetics::MagSample> ToMagSamples(const std::vector<TurntableRow>& rows, size_t index) {
  std::vector<magnetics::MagSample> out;
  out.reserve(rows.size());
  for (const auto& r : rows) {
    magnetics::MagSample s;
    s.plane = r.plane;
    s.control_u = r.control_u;
    s.current_A = r.current_A;
    s.angle_deg = r.angle_deg;
    s.mag_B_uT = r.mag_B_uT.at(index);
    s.q_NB = r.q_NB;
    s.earth_B_uT = r.earth_B_uT;
    out.push_back(s);
  }
  return out;
}

}  // namespace hexsim::sim
