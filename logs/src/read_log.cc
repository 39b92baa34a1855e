#include "hexsim/logs/read_log.h"

#include <fmt/format.h>

#include "hexsim/common/atomic_file.h"
#include "hexsim/logs/current_check.h"
#include "hexsim/logs/dataflash_import.h"
#include "hexsim/logs/dataflash_plausibility.h"
#include "hexsim/logs/dataflash_text.h"
#include "hexsim/logs/ulog.h"
#include "hexsim/logs/ulog_import.h"

namespace hexsim::logs {
namespace {

bool IsDataFlash(const std::string& bytes) {
  return bytes.size() >= 2 && static_cast<unsigned char>(bytes[0]) == kDataFlashHead1 &&
         static_cast<unsigned char>(bytes[1]) == kDataFlashHead2;
}

std::string BaseName(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

void Say(std::vector<std::string>* notes, std::string line) {
  if (notes != nullptr) notes->push_back(std::move(line));
}

}  // namespace

Result<FlightLog> ReadAnyFlightLog(const std::string& path, std::vector<std::string>* notes) {
  auto read = ReadFile(path);
  if (!read.ok()) return read.status();
  std::string text_note;
  auto bytes = DataFlashBinaryBytes(*read, path, &text_note);  // a text .log as its binary
  if (!bytes.ok()) return bytes.status();
  if (!text_note.empty()) Say(notes, text_note);
  FlightLog log;
  const bool is_csv = !IsDataFlash(*bytes) && !IsULog(*bytes);
  if (IsDataFlash(*bytes)) {
    auto r = ImportDataFlash(*bytes, path);
    if (!r.ok()) return r.status();
    for (auto& line : DamageLines(path, r->damage, r->records, r->records_accepted)) Say(notes, std::move(line));
    for (auto& w : r->warnings) Say(notes, std::move(w));
    log = std::move(r->log);
    Say(notes, fmt::format("{}: ArduPilot DataFlash log, imported in memory ({} rows; `hexsim import {} --out log.csv` "
                           "writes the FlightLog)",
                           path, log.rows(), path));
  } else if (IsULog(*bytes)) {
    auto r = ImportULog(*bytes, path);
    if (!r.ok()) return r.status();
    for (auto& w : r->warnings) Say(notes, std::move(w));
    log = std::move(r->log);
    Say(notes, fmt::format("{}: PX4 ULog, imported in memory ({} rows; `hexsim import {} --out log.csv` writes the "
                           "FlightLog)",
                           path, log.rows(), path));
  } else {
    auto r = ReadFlightLog(path);
    if (!r.ok()) return r.status();
    log = std::move(r).value();
  }
  // As `hexsim import` names it (an imported CSV keeps the name of the log it came from).
  if (!is_csv || !log.meta.contains("source")) log.meta["source"] = BaseName(path);
  const CurrentSensorCheck current = CurrentSensorOf(log);
  if (!current.usable) Say(notes, path + ": " + current.why);
  return log;
}

}  // namespace hexsim::logs
