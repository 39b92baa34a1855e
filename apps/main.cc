// hexsim: the command line. Each subcommand lives in its own cmd_*.cc file.
#include <cstdio>
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
  }
  return exit_code;
}
