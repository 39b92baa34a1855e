// hexsim field LAT LON ALT_M DATE: the World Magnetic Model's field at a place and date.
#include <cstdio>
#include <string>

#include <nlohmann/json.hpp>

#include "cli_util.h"
#include "commands.h"
#include "hexsim/magnetics/wmm.h"

namespace hexsim::app {
namespace {

struct FieldArgs {
  double lat_deg = 0.0, lon_deg = 0.0, alt_m = 0.0;
  std::string date, model;
  bool json = false, allow_extrapolation = false;
};

Status FieldCommand(const FieldArgs& a) {
  auto year = magnetics::DecimalYearFromDate(a.date);
  if (!year.ok()) return year.status();
  const magnetics::GeodeticPoint where{a.lat_deg, a.lon_deg, a.alt_m};
  auto f = a.model.empty() ? magnetics::EvaluateWmm(where, *year, a.allow_extrapolation)
                           : magnetics::EvaluateWmmModel(a.model, where, *year, a.allow_extrapolation);
  if (!f.ok()) return f.status();
  const Eigen::Vector3d B_nT = f->B_N_uT * 1000.0;
  if (a.json) {
    const nlohmann::json j = {{"schema", "hexsim.field/1"},   {"model", f->model},
                              {"model_id", f->model_id},      {"lat_deg", a.lat_deg},
                              {"lon_deg", a.lon_deg},         {"alt_m", a.alt_m},
                              {"date", a.date},               {"decimal_year", *year},
                              {"north_nT", B_nT(0)},          {"east_nT", B_nT(1)},
                              {"down_nT", B_nT(2)},           {"horizontal_nT", f->horizontal_uT * 1000.0},
                              {"total_nT", f->total_uT * 1000.0}, {"declination_deg", f->declination_deg},
                              {"inclination_deg", f->inclination_deg}};
    std::printf("%s\n", j.dump(2).c_str());
    return Status::Ok();
  }
  std::printf("model        %s (%s), decimal year %.4f\n", f->model.c_str(), f->model_id.c_str(), *year);
  std::printf("N (X)        %10.1f nT\nE (Y)        %10.1f nT\nD (Z)        %10.1f nT\n", B_nT(0), B_nT(1), B_nT(2));
  std::printf("H            %10.1f nT\nF            %10.1f nT\n", f->horizontal_uT * 1000.0, f->total_uT * 1000.0);
  std::printf("declination  %10.3f deg\ninclination  %10.3f deg\n", f->declination_deg, f->inclination_deg);
  return Status::Ok();
}

}  // namespace

void AddFieldCommand(CLI::App& app, int* exit_code) {
  auto a = std::make_shared<FieldArgs>();
  CLI::App* c = app.add_subcommand("field", "World Magnetic Model field at LAT LON ALT_M DATE (N, E, D, H, F, angles)");
  c->add_option("lat", a->lat_deg, "Geodetic latitude, deg (north positive)")->required();
  c->add_option("lon", a->lon_deg, "Longitude, deg (east positive)")->required();
  c->add_option("alt", a->alt_m, "Height above the WGS-84 ellipsoid, m")->required();
  c->add_option("date", a->date, "Decimal year (2016.5) or YYYY-MM-DD")->required();
  c->add_option("--model", a->model, "wmm2015|wmm2015v2|wmm2020|wmm2025 (default: picked by the date)");
  c->add_flag("--json", a->json, "Print hexsim.field/1 JSON instead of text");
  c->add_flag("--allow-field-extrapolation", a->allow_extrapolation, "Allow a date outside the model's validity");
  c->callback([a, exit_code] { *exit_code = Report(FieldCommand(*a)); });
}

}  // namespace hexsim::app
