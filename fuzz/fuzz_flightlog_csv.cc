// libFuzzer target: the FlightLog CSV reader on arbitrary text. A log it accepts must write back
// to CSV and parse to the same table (shortest round-trip numbers, empty cells kept).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "hexsim/logs/flight_log.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  auto log = hexsim::logs::ParseFlightLogCsv(text, "fuzz.csv");
  if (!log.ok()) {
    if (log.status().code() != hexsim::StatusCode::kBadInput || log.status().message().empty()) std::abort();
    return 0;
  }
  auto back = hexsim::logs::ParseFlightLogCsv(hexsim::logs::FlightLogToCsv(*log), "again.csv");
  if (!back.ok() || back->rows() != log->rows() || back->columns() != log->columns()) std::abort();
  for (size_t c = 0; c < log->columns().size(); ++c) {
    for (size_t r = 0; r < log->rows(); ++r) {
      const double a = log->At(r, c), b = back->At(r, c);
      if (!(a == b || (std::isnan(a) && std::isnan(b)))) std::abort();
    }
  }
  return 0;
}
