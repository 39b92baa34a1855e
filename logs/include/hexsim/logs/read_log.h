// Any flight log a command is given, as a FlightLog: an ArduPilot DataFlash .bin or a PX4 .ulg
// (decided by content) is imported in memory, anything else is read as a FlightLog CSV with its meta
// side file and streams (ReadFlightLog).
#pragma once

#include <string>
#include <vector>

#include "hexsim/common/status.h"
#include "hexsim/logs/flight_log.h"

namespace hexsim::logs {

// `notes` (optional) gets one line per thing worth saying: that the log was imported (and how to
// write the import), damage that did not refuse it, the importer's warnings, and an unusable current.
Result<FlightLog> ReadAnyFlightLog(const std::string& path, std::vector<std::string>* notes = nullptr);

}  // namespace hexsim::logs
