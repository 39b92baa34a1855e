#include "hexsim/sim/world.h"

#include <cmath>

#include "hexsim/common/yaml_reader.h"

namespace hexsim::sim {

Result<WorldParams> ParseWorld(const YAML::Node& root, const std::string& file) {
  WorldParams w;
  YamlReader r(root, file);
  r.Opt("name", &w.name);
  r.Child("home", [&](YamlReader& h) {
    h.Req("lat_deg", &w.home_lat_deg, InRange(-90, 90));
    h.Req("lon_deg", &w.home_lon_deg, InRange(-180, 180));
    h.Opt("alt_m", &w.home_alt_m, InRange(-500, 9000));
  }, true);
  r.Req("date_decimal_year", &w.date_decimal_year, InRange(1900, 2100));
  r.Opt("allow_field_extrapolation", &w.allow_field_extrapolation);
  r.Opt("air_density_kgpm3", &w.air_density_kgpm3, InRange(0.3, 1.5));
  r.Child("wind", [&](YamlReader& wr) {
    wr.Opt("mean_N_mps", &w.wind.mean_N_mps);
    wr.Opt("turbulence_std_mps", &w.wind.turbulence_std_mps, InRange(0, 20));
    wr.Opt("turbulence_tau_s", &w.wind.turbulence_tau_s, Positive());
  });
  r.Opt("anomaly_N_uT", &w.anomaly_N_uT);
  r.Opt("ground_friction", &w.ground_friction, InRange(0, 5));
  HEXSIM_RETURN_IF_ERROR(r.Finish());
  return w;
}

WindModel::WindModel(const WindParams& params, uint64_t seed)
    : params_(params), rng_(seed, "wind"), wind_N_mps_(params.mean_N_mps) {
  if (params_.turbulence_std_mps > 0) gust_N_mps_ = rng_.Normal3(params_.turbulence_std_mps);
  wind_N_mps_ = params_.mean_N_mps + gust_N_mps_;
}

Eigen::Vector3d WindModel::Step(double dt_s) {
  if (params_.turbulence_std_mps > 0) {
    const double a = std::exp(-dt_s / params_.turbulence_tau_s);
    const double s = params_.turbulence_std_mps * std::sqrt(1.0 - a * a);
    gust_N_mps_ = a * gust_N_mps_ + rng_.Normal3(s);
  }
  wind_N_mps_ = params_.mean_N_mps + gust_N_mps_;
  return wind_N_mps_;
}

}  // namespace hexsim::sim
