// hexsim: the command line. Each subcommand lives in its own cmd_*.cc file.
#include <cstdio>
#include <exception>
#include <new>
#include <stdexcept>
#include <string>

#include <CLI/CLI.hpp>

#include "cli_util.h"
#include "commands.h"
#include "hexsim/common/paths.h"

int main(int argc, char** argv) {
  CLI::App app{"hexsim: a multirotor flight simulator with a physical compass model"};
  app.set_version_flag("--version", std::string("hexsim ") + hexsim::Version());
  app.require_subcommand(1);
  int exit_code = 0;
  hexsim::app::RegisterCommands(app, &exit_code);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::string what = e.what();
    for (char& c : what) {
      if (c == '\n') c = ' ';
    }
    std::fprintf(stderr, "hexsim: %s (see hexsim --help)\n", what.c_str());
    return 2;
  } catch (const std::exception& e) {
    // Nothing escapes as a signal: whatever a command did not turn into a Status ends here, as one
    // line. Logic errors (argument, range, length, domain) come from input a check let through:
    // bad input, exit 2; anything else (allocation, runtime) is a failure of the run, exit 3.
    const bool input = dynamic_cast<const std::logic_error*>(&e) != nullptr;
    return hexsim::app::ReportUnexpected(e.what(), input ? 2 : 3);
  } catch (...) {
    return hexsim::app::ReportUnexpected("unknown exception", 3);
  }
  return exit_code;
}
