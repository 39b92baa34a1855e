// libFuzzer target: the command line's flag parsing, every subcommand. The input is NUL-separated
// arguments: a first argument naming a subcommand is taken as it is (the seeds in fuzz/corpus/cli),
// else the first byte picks one (so every one is reached from any input) and the rest follow it.
// The parse either succeeds or ends in a CLI11 ParseError (main prints it as one line and exits 2);
// any other exception escaping the parse is what main would print as "unexpected error": the target
// aborts on it. The commands' work is not run (a run flies for seconds, serve-px4 waits for a
// client, others write files), except `field`'s, which only computes and prints.
// Each input's App holds only the part of RegisterCommands (apps/commands.cc) that registers its
// subcommand: CLI11 parses a subcommand's arguments without looking at its siblings (the App takes
// exactly one), so the parse is the one hexsim makes, and one execution costs ~1/10 of building every
// command (fuzz/fuzz.sh needs 100 000 of them within its time cap). LLVMFuzzerInitialize aborts when
// the parts below and RegisterCommands register different subcommands (a command added to one only).
#include <fcntl.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "commands.h"

namespace {

constexpr size_t kMaxArgs = 24;
constexpr size_t kMaxArgBytes = 512;

using Registrar = void (*)(CLI::App&, int*);
// RegisterCommands' parts, in its order.
constexpr Registrar kParts[] = {
    hexsim::app::AddRunCommand,      hexsim::app::AddGapCommand,          hexsim::app::AddIdentifyCommand,
    hexsim::app::AddBatchCommands,   hexsim::app::AddCalibrationCommands, hexsim::app::AddCalibrateCommand,
    hexsim::app::AddFieldCommand,    hexsim::app::AddCompareCommand,      hexsim::app::AddImportCommand,
    hexsim::app::AddPlotCommand,     hexsim::app::AddToolCommands,        hexsim::app::AddServePx4Command};

struct Subcommand {
  std::string name;
  Registrar part;
};

// Every subcommand in RegisterCommands' order (the first byte of an input picks one by its index).
std::vector<Subcommand> subcommands;

std::vector<std::string> NamesOf(CLI::App& app) {
  std::vector<std::string> names;
  for (const CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) names.push_back(sub->get_name());
  return names;
}

// Each command's work stops once its flags are parsed and checked: CLI11 runs a subcommand's
// parse-complete callback after its options' conversions, requirements and exclusions, and before
// its final callback (the work); throwing Success there ends the parse as --help does. (Replacing
// the final callback instead would free the argument structs its lambda owns, which the options
// still write into.) `field` keeps its work: it only computes and prints.
void StopBeforeTheWork(CLI::App* app) {
  for (CLI::App* sub : app->get_subcommands([](CLI::App*) { return true; })) {
    if (!sub->get_subcommands([](CLI::App*) { return true; }).empty()) {
      StopBeforeTheWork(sub);
    } else if (sub->get_name() != "field") {
      sub->parse_complete_callback([] { throw CLI::Success(); });
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // The commands print; the fuzzer's own report goes to stderr, which stays.
  const int null_fd = ::open("/dev/null", O_WRONLY);
  if (null_fd >= 0) ::dup2(null_fd, STDOUT_FILENO);
  int exit_code = 0;
  CLI::App all{"hexsim"};
  hexsim::app::RegisterCommands(all, &exit_code);
  std::vector<std::string> from_parts;
  std::vector<Registrar> part_of;
  for (Registrar part : kParts) {
    CLI::App one{"hexsim"};
    part(one, &exit_code);
    for (std::string& name : NamesOf(one)) {
      from_parts.push_back(std::move(name));
      part_of.push_back(part);
    }
  }
  if (from_parts != NamesOf(all)) {
    std::fprintf(stderr, "fuzz_cli: kParts and RegisterCommands register different subcommands\n");
    std::abort();
  }
  for (size_t i = 0; i < from_parts.size(); ++i) subcommands.push_back({from_parts[i], part_of[i]});
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  if (subcommands.empty()) std::abort();
  // A first argument naming a subcommand (the seeds) is taken as it is; else the first byte picks one.
  size_t begin = 0;
  const std::string first(reinterpret_cast<const char*>(data), strnlen(reinterpret_cast<const char*>(data), size));
  const Subcommand* chosen = nullptr;
  for (const Subcommand& sub : subcommands) {
    if (sub.name == first) chosen = &sub;
  }
  std::vector<std::string> args = {"hexsim"};
  if (chosen == nullptr) {
    chosen = &subcommands[data[0] % subcommands.size()];
    args.push_back(chosen->name);
    begin = 1;
  }
  CLI::App app{"hexsim"};
  app.require_subcommand(1);
  int exit_code = 0;
  chosen->part(app, &exit_code);
  StopBeforeTheWork(&app);
  std::string cur;
  for (size_t i = begin; i < size && args.size() < kMaxArgs; ++i) {
    const char c = static_cast<char>(data[i]);
    if (c == '\0') {
      args.push_back(cur);
      cur.clear();
    } else if (cur.size() < kMaxArgBytes) {
      cur.push_back(c);
    }
  }
  if (!cur.empty() && args.size() < kMaxArgs) args.push_back(cur);
  std::vector<const char*> argv;
  argv.reserve(args.size());
  for (const auto& a : args) argv.push_back(a.c_str());
  try {
    app.parse(static_cast<int>(argv.size()), argv.data());
  } catch (const CLI::ParseError&) {
    // --help, --version, a bad value or flag: main's one line and exit 2 (0 for help).
  }
  // Anything else propagates: libFuzzer reports the uncaught exception as a crash.
  return 0;
}
