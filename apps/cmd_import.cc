// hexsim import LOG.bin --out log.csv | hexsim import --info LOG.bin
#include <cstdio>
#include <string>

#include "cli_util.h"
#include "commands.h"
#include "hexsim/common/atomic_file.h"
#include "hexsim/common/paths.h"
#include "hexsim/logs/current_check.h"
#include "hexsim/logs/dataflash_import.h"
#include "hexsim/logs/dataflash_text.h"
#include "hexsim/logs/ulog.h"
#include "hexsim/logs/ulog_import.h"

namespace hexsim::app {

namespace {

struct ImportArgs {
  std::string log, out;
  bool info = false;
};

Status ImportCommand(const ImportArgs& a) {
  auto read = ReadFile(a.log);
  if (!read.ok()) return read.status();
  std::string text_note;
  auto bytes = logs::DataFlashBinaryBytes(*read, a.log, &text_note);  // a text .log as its binary
  if (!bytes.ok()) return bytes.status();
  if (!text_note.empty()) std::fprintf(stderr, "hexsim: %s\n", text_note.c_str());
  if (a.info) {
    // Bad input as for the import itself: an empty file, or one without a single DataFlash message.
    if (bytes->empty()) return Status::BadInput(a.log + ": empty file");
    if (logs::IsULog(*bytes)) {
      auto u = logs::ParseULog(*bytes, a.log);
      if (!u.ok()) return u.status();
      std::fputs(logs::ULogInfo(*u, a.log).c_str(), stdout);
      return Status::Ok();
    }
    if (logs::DataFlashInfoJson(*bytes, a.log)["types"].empty()) {
      return Status::BadInput(a.log + ": not an ArduPilot DataFlash log: no readable messages");
    }
    std::fputs(logs::DataFlashInfo(*bytes, a.log).c_str(), stdout);
    return Status::Ok();
  }
  if (a.out.empty()) return Status::BadInput("import: --out is required (or --info)");
  if (logs::IsULog(*bytes)) {
    auto u = logs::ImportULog(*bytes, a.log);
    if (!u.ok()) return u.status();
    for (const auto& w : u->warnings) std::fprintf(stderr, "hexsim: warning: %s\n", w.c_str());
    OutputDirectory udir;
    HEXSIM_RETURN_IF_ERROR(udir.Open(DirName(a.out)));
    HEXSIM_RETURN_IF_ERROR(logs::WriteFlightLog(u->log, a.out));
    udir.Commit();
    std::printf("import: PX4 ULog, %zu rows, %zu columns -> %s\n", u->log.rows(), u->log.columns().size(), a.out.c_str());
    std::printf("%s\n", logs::CurrentCheckLine(logs::CurrentSensorOf(u->log)).c_str());
    return Status::Ok();
  }
  auto result = logs::ImportDataFlash(*bytes, a.log, logs::ImportOptions{});
  if (!result.ok()) return result.status();
  // Damage that did not refuse the log is still said, once, on stderr (the counts are in the meta).
  for (const auto& line : logs::DamageLines(a.log, result->damage, result->records, result->records_accepted)) {
    std::fprintf(stderr, "hexsim: %s\n", line.c_str());
  }
  for (const auto& w : result->warnings) std::fprintf(stderr, "hexsim: warning: %s\n", w.c_str());
  OutputDirectory dir;
  HEXSIM_RETURN_IF_ERROR(dir.Open(DirName(a.out)));
  HEXSIM_RETURN_IF_ERROR(logs::WriteImport(*result, a.out));
  dir.Commit();
  std::printf("import: %zu rows, %zu columns -> %s (+ %zu native-rate streams <log>.<stream>.csv)\n", result->log.rows(),
              result->log.columns().size(), a.out.c_str(), result->log.stream_names().size());
  std::printf("%s\n", logs::CurrentCheckLine(logs::CurrentSensorOf(result->log)).c_str());
  return Status::Ok();
}

}  // namespace

void AddImportCommand(CLI::App& app, int* exit_code) {
  auto a = std::make_shared<ImportArgs>();
  CLI::App* c = app.add_subcommand("import", "Real flight log (ArduPilot DataFlash .bin or PX4 ULog .ulg) -> FlightLog CSV + meta");
  c->add_option("log", a->log, "DataFlash .bin or ULog .ulg file (detected from content)")->required();
  c->add_flag("--info", a->info, "Print message types (ULog: topics), counts, rates, time span and parameters of interest");
  c->add_option("--out", a->out, "log.csv to write (log.meta.json and log.<stream>.csv beside it)");
  c->callback([a, exit_code] { *exit_code = Report(ImportCommand(*a)); });
}

}  // namespace hexsim::app
