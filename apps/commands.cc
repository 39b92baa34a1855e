#include "commands.h"

namespace hexsim::app {

void RegisterCommands(CLI::App& app, int* exit_code) {
  AddRunCommand(app, exit_code);
}

}  // namespace hexsim::app
