// libFuzzer target: the DataFlash reader and importer on arbitrary bytes, and the text form's
// re-encoder (dataflash_text.h) on the same bytes (its output read back by the binary reader).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "hexsim/logs/dataflash.h"
#include "hexsim/logs/dataflash_import.h"
#include "hexsim/logs/dataflash_text.h"
#include "hexsim/logs/flight_log.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);

  // Every field of every message decodes without reading outside the buffer.
  hexsim::logs::DataFlashReader reader(bytes);
  hexsim::logs::DataFlashMessage m;
  size_t messages = 0;
  while (reader.Next(&m)) {
    ++messages;
    for (size_t i = 0; i < m.format().format.size(); ++i) (void)m.GetIndex(i);
    (void)m.BootTime_s();
  }
  if (reader.damage().skipped_bytes > size) std::abort();

  (void)hexsim::logs::DataFlashInfoJson(bytes, "fuzz.bin").dump();

  // Any bytes as text: BadInput or binary messages the reader accepts whole (nothing skipped).
  auto text = hexsim::logs::DataFlashTextToBinary(bytes, "fuzz.log");
  if (text.ok()) {
    hexsim::logs::DataFlashReader back(*text);
    while (back.Next(&m)) {
    }
    if (back.damage().skipped_bytes != 0) std::abort();
  } else if (text.status().code() != hexsim::StatusCode::kBadInput) {
    std::abort();
  }

  auto result = hexsim::logs::ImportDataFlash(bytes, "fuzz.bin");
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
