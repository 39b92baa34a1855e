// The environment a vehicle flies in: where and when (for the Earth field), air, wind, ground.
#pragma once

#include <string>

#include <Eigen/Core>
#include <yaml-cpp/yaml.h>

#include "hexsim/common/rng.h"
#include "hexsim/common/status.h"

namespace hexsim::sim {

struct WindParams {
  Eigen::Vector3d mean_N_mps = Eigen::Vector3d::Zero();
  double turbulence_std_mps = 0.0;  // per-axis standard deviation of the gusts
  double turbulence_tau_s = 2.0;    // correlation time (first-order Gauss–Markov)
};

struct WorldParams {
  std::string name = "default";
  double home_lat_deg = 0.0;
  double home_lon_deg = 0.0;
  double home_alt_m = 0.0;
  double date_decimal_year = 2026.0;
  bool allow_field_extrapolation = false;
  double air_density_kgpm3 = 1.225;
  WindParams wind;
  // A local magnetic anomaly added to the model field (NED, µT); zero for a clean site.
  Eigen::Vector3d anomaly_N_uT = Eigen::Vector3d::Zero();
  double ground_friction = 0.8;
};

Result<WorldParams> ParseWorld(const YAML::Node& root, const std::string& file);

// Wind with first-order Gauss–Markov turbulence, exactly discretised:
// g_{k+1} = a·g_k + σ·sqrt(1 − a²)·n,  a = exp(−dt/τ).
class WindModel {
 public:
  WindModel(const WindParams& params, uint64_t seed);
  // Advances by dt and returns the wind velocity in NED.
  Eigen::Vector3d Step(double dt_s);
  const Eigen::Vector3d& current_N_mps() const { return wind_N_mps_; }
  // Sets the mean wind (e.g. a mission override or a gust injection).
  void SetMean(const Eigen::Vector3d& mean_N_mps) { params_.mean_N_mps = mean_N_mps; }

 private:
  WindParams params_;
  RngStream rng_;
  Eigen::Vector3d gust_N_mps_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d wind_N_mps_ = Eigen::Vector3d::Zero();
};

}  // namespace hexsim::sim
