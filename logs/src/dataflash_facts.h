// What a DataFlash log says of itself (private to logs/): its text messages (firmware, frame), the
// parameters worth keeping, its damage counts as JSON, and GPS time as UTC. Shared by the importer
// (dataflash_import.cc) and `hexsim info` (dataflash_info.cc).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hexsim/logs/dataflash.h"

namespace hexsim::logs::internal {

bool StartsWith(const std::string& s, const std::string& prefix);
// Log text as printable ASCII (damaged bytes become '?'), so JSON output stays valid UTF-8.
std::string Printable(const std::string& s);
// Motors of a frame named in the "Frame: QUAD" message; 0 when the name is not a multirotor's.
int MotorsForFrameName(const std::string& frame);
// Motors of FRAME_CLASS (ArduCopter 3.5+); 0 for a class without a fixed count.
int MotorsForFrameClass(int frame_class);
// Days from 1970-01-01 to a civil date (proleptic Gregorian).
int64_t DaysFromCivil(int64_t y, unsigned m, unsigned d);
// Unix seconds (UTC) of a GPS week and time of week, leap seconds removed.
double UnixFromGps(int week, double tow_s);
// "YYYY-MM-DDTHH:MM:SSZ".
std::string IsoUtc(double unix_s);
nlohmann::json DamageJson(const DataFlashDamage& d);
// The firmware line among the log's text messages ("" when none names ArduPilot).
std::string FirmwareOf(const std::vector<std::string>& texts);
// copter, plane, rover, sub or unknown, from the firmware line.
std::string VehicleTypeOf(const std::string& firmware);
// The frame named by a "Frame: ..." message ("" when none).
std::string FrameNameOf(const std::vector<std::string>& texts);
// The parameters IsParameterOfInterest keeps, as a JSON object.
nlohmann::json ParamsOfInterest(const std::map<std::string, double>& params);

}  // namespace hexsim::logs::internal
