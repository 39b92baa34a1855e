// libFuzzer target: the ULog parser and importer on arbitrary bytes.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "hexsim/logs/flight_log.h"
#include "hexsim/logs/ulog.h"
#include "hexsim/logs/ulog_import.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  auto parsed = hexsim::logs::ParseULog(bytes, "fuzz.ulg");
  if (parsed.ok()) {
    // Every field of every record decodes inside its record.
    for (const auto& t : parsed->topics) {
      for (size_t i = 0; i < t.records.size() && i < 64; ++i) {
        for (const auto& f : t.fields) (void)t.Get(i, f.name);
      }
    }
    if (parsed->bytes_skipped > size) std::abort();
  } else if (parsed.status().code() != hexsim::StatusCode::kBadInput) {
    std::abort();
  }
  auto result = hexsim::logs::ImportULog(bytes, "fuzz.ulg");
  if (!result.ok()) {
    if (result.status().code() != hexsim::StatusCode::kBadInput) std::abort();
    return 0;
  }
  // What the importer produced must be a valid FlightLog with valid JSON meta.
  (void)result->log.meta.dump();
  auto back = hexsim::logs::ParseFlightLogCsv(hexsim::logs::FlightLogToCsv(result->log), "fuzz.csv");
  if (!back.ok() || back->rows() != result->log.rows()) std::abort();
  return 0;
}
