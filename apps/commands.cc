#include "commands.h"

namespace hexsim::app {

void RegisterCommands(CLI::App& app, int* exit_code) {
  AddRunCommand(app, exit_code);
  AddGapCommand(app, exit_code);
  AddIdentifyCommand(app, exit_code);
  AddBatchCommands(app, exit_code);
  AddCalibrationCommands(app, exit_code);
  AddCalibrateCommand(app, exit_code);
  AddFieldCommand(app, exit_code);
  AddCompareCommand(app, exit_code);
  AddImportCommand(app, exit_code);
  AddPlotCommand(app, exit_code);
  AddToolCommands(app, exit_code);
  AddServePx4Command(app, exit_code);
}

}  // namespace hexsim::app
