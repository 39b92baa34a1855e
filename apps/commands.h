#pragma once

#include <CLI/CLI.hpp>

namespace hexsim::app {

// Adds every subcommand to `app`; the one that runs stores its exit code in *exit_code.
void RegisterCommands(CLI::App& app, int* exit_code);

void AddRunCommand(CLI::App& app, int* exit_code);
void AddGapCommand(CLI::App& app, int* exit_code);
void AddIdentifyCommand(CLI::App& app, int* exit_code);
void AddBatchCommands(CLI::App& app, int* exit_code);  // batch, batch-report, batch-merge
void AddBatchReportCommand(CLI::App& app, int* exit_code);
void AddCalibrationCommands(CLI::App& app, int* exit_code);
void AddCalibrateCommand(CLI::App& app, int* exit_code);
void AddFieldCommand(CLI::App& app, int* exit_code);
void AddCompareCommand(CLI::App& app, int* exit_code);
void AddImportCommand(CLI::App& app, int* exit_code);
void AddPlotCommand(CLI::App& app, int* exit_code);
void AddToolCommands(CLI::App& app, int* exit_code);
void AddServePx4Command(CLI::App& app, int* exit_code);

}  // namespace hexsim::app
