// `hexsim gap diagnose`'s flow as a library call (the CLI and the Python module share it): choose the
// vehicle to diagnose a real log against, diagnose, and the updated vehicle YAML.
//
// With a vehicle given (a name under worlds/vehicles or a YAML path), the whole log is diagnosed
// against it and the vehicle identified from the log is only compared with it. Without one, the
// log's frame picks a shipped base vehicle, the vehicle is identified on the even time blocks of the
// flight windows and the diagnosis runs on the odd (held-out) blocks only (CONTRACTS, real data).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hexsim/common/status.h"
#include "hexsim/gap/diagnose.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::experiments {

struct LogDiagnosisOptions {
  std::string vehicle;           // name or YAML path; empty: identify the vehicle from the log
  std::string log_name;          // the log's name in messages and in the report
  uint64_t seed = 1;             // bootstrap seed
  double from_s = 0.0, to_s = 0.0;  // both 0: the flight windows; else this log-time span
  int threads = 1;               // channels diagnosed at once (gap::DiagnoseOptions::threads)
};

struct LogDiagnosis {
  gap::GapReport report;
  vehicle::VehicleParams vehicle;  // the vehicle diagnosed against (identified, or as given)
  std::string vehicle_yaml;        // its YAML text (written as identified.yaml when identified)
  std::string updated_yaml;        // the vehicle YAML with the diagnosis' fits applied
  std::string stem;                // the given file's stem, or "identified"
  bool identified = false;         // no vehicle was given
  nlohmann::json vehicle_source = nlohmann::json::object();  // gap.json's "vehicle_source"
  std::vector<std::string> lines;  // what to say about the vehicle, one line each
};

// Bad input (no rows, no frame to choose a base by, --to before --from, a vehicle that does not
// load) is kBadInput naming the field; the diagnosis' own errors carry the log's name.
Result<LogDiagnosis> DiagnoseLog(const logs::FlightLog& log, const LogDiagnosisOptions& options);

// gap.json: gap::ToJson of the report with "vehicle_source".
nlohmann::json LogDiagnosisJson(const LogDiagnosis& diagnosis);

}  // namespace hexsim::experiments
