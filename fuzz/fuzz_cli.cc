// libFuzzer target: the command line's flag parsing, every subcommand. The input is NUL-separated
// arguments: a first argument naming a subcommand is taken as it is (the seeds in fuzz/corpus/cli),
// else the first byte picks one (so every one is reached from any input) and the rest follow it.
// The parse either succeeds or ends in a CLI11 ParseError (main prints it as one line and exits 2);
// any other exception escaping the parse is what main would print as "unexpected error": the target
// aborts on it. The commands' work is not run (a run flies for seconds, serve-px4 waits for a
// client, others write files), except `field`'s, which only computes and prints.
#include <fcntl.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "commands.h"

namespace {

constexpr size_t kMaxArgs = 24;
constexpr size_t kMaxArgBytes = 512;

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
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  CLI::App app{"hexsim"};
  app.require_subcommand(1);
  int exit_code = 0;
  hexsim::app::RegisterCommands(app, &exit_code);
  StopBeforeTheWork(&app);
  const auto subs = app.get_subcommands([](CLI::App*) { return true; });
  if (subs.empty()) std::abort();
  // A first argument naming a subcommand (the seeds) is taken as it is; else the first byte picks one.
  std::vector<std::string> args = {"hexsim"};
  size_t begin = 0;
  const std::string first(reinterpret_cast<const char*>(data), strnlen(reinterpret_cast<const char*>(data), size));
  bool named = false;
  for (const CLI::App* sub : subs) named = named || sub->get_name() == first;
  if (!named) {
    args.push_back(subs[data[0] % subs.size()]->get_name());
    begin = 1;
  }
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
