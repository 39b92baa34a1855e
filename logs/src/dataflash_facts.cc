#include "dataflash_facts.h"

#include <cmath>
#include <ctime>

#include "hexsim/logs/dataflash_import.h"

namespace hexsim::logs {
namespace internal {
namespace {

// GPS epoch 1980-01-06 in Unix seconds.
constexpr double kGpsEpochUnix_s = 315964800.0;
constexpr double kSecondsPerWeek = 604800.0;

// GPS - UTC leap seconds at a GPS time (table to 2017; none announced since).
double LeapSeconds(double gps_s) {
  const double unix_s = gps_s + kGpsEpochUnix_s;
  struct Step { int64_t y; unsigned m; double leap; };
  static const Step kSteps[] = {{2017, 1, 18}, {2015, 7, 17}, {2012, 7, 16}, {2009, 1, 15}, {2006, 1, 14}};
  for (const auto& s : kSteps) {
    if (unix_s >= static_cast<double>(DaysFromCivil(s.y, s.m, 1)) * 86400.0) return s.leap;
  }
  return 13.0;
}

}  // namespace

bool StartsWith(const std::string& s, const std::string& prefix) { return s.compare(0, prefix.size(), prefix) == 0; }

std::string Printable(const std::string& s) {
  std::string out = s;
  for (char& ch : out) {
    if (ch < 0x20 || ch > 0x7e) ch = '?';
  }
  return out;
}

int MotorsForFrameName(const std::string& frame) {
  static const std::pair<const char*, int> kFrames[] = {
      {"OCTA_QUAD", 8}, {"OCTAQUAD", 8}, {"DODECA", 12}, {"QUAD", 4}, {"HEXA", 6}, {"OCTA", 8},
      {"Y6", 6}, {"TRI", 3}, {"DECA", 10}};
  for (const auto& [name, n] : kFrames) {
    if (frame.find(name) != std::string::npos) return n;
  }
  return 0;
}

int MotorsForFrameClass(int frame_class) {
  switch (frame_class) {
    case 1: return 4;
    case 2: return 6;
    case 3: return 8;
    case 4: return 8;
    case 5: return 6;
    case 7: return 3;
    case 12: return 12;
    case 14: return 10;
    default: return 0;
  }
}

int64_t DaysFromCivil(int64_t y, unsigned m, unsigned d) {
  y -= m <= 2;
  const int64_t era = (y >= 0 ? y : y - 399) / 400;
  const unsigned yoe = static_cast<unsigned>(y - era * 400);
  const unsigned doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + static_cast<int64_t>(doe) - 719468;
}

double UnixFromGps(int week, double tow_s) {
  const double gps_s = week * kSecondsPerWeek + tow_s;
  return gps_s + kGpsEpochUnix_s - LeapSeconds(gps_s);
}

std::string IsoUtc(double unix_s) {
  const std::time_t t = static_cast<std::time_t>(std::floor(unix_s));
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

nlohmann::json DamageJson(const DataFlashDamage& d) {
  return {{"skipped_bytes", d.skipped_bytes},
          {"bad_header_runs", d.bad_header_runs},
          {"unknown_type_messages", d.unknown_type_messages},
          {"bad_formats", d.bad_formats},
          {"misaligned_messages", d.misaligned_messages},
          {"truncated_tail_bytes", d.truncated_tail_bytes}};
}

std::string FirmwareOf(const std::vector<std::string>& texts) {
  for (const auto& t : texts) {
    if (t.find("APM:") != std::string::npos || t.find("Ardu") != std::string::npos ||
        t.find("ArduPilot") != std::string::npos) {
      return t;
    }
  }
  return "";
}

std::string VehicleTypeOf(const std::string& firmware) {
  if (firmware.find("Copter") != std::string::npos) return "copter";
  if (firmware.find("Plane") != std::string::npos) return "plane";
  if (firmware.find("Rover") != std::string::npos) return "rover";
  if (firmware.find("Sub") != std::string::npos) return "sub";
  return "unknown";
}

std::string FrameNameOf(const std::vector<std::string>& texts) {
  for (const auto& t : texts) {
    if (StartsWith(t, "Frame: ")) return t.substr(7);
  }
  return "";
}

nlohmann::json ParamsOfInterest(const std::map<std::string, double>& params) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [k, v] : params) {
    if (IsParameterOfInterest(k)) j[k] = v;
  }
  return j;
}

}  // namespace internal

using internal::DaysFromCivil;
using internal::IsoUtc;
using internal::StartsWith;
using internal::UnixFromGps;

bool IsParameterOfInterest(const std::string& n) {
  static const char* kPrefixes[] = {"COMPASS_", "MOT_PWM_", "MOT_BAT_", "RC3_", "BATT", "FRAME", "AHRS_ORIENTATION",
                                    "MOT_SPIN_", "MOT_THST_", "INS_GYROFFS", "INS_ACCOFFS"};
  for (const char* p : kPrefixes) {
    if (StartsWith(n, p)) return true;
  }
  return false;
}

double DecimalYearFromGps(int week, double time_of_week_s) { return DecimalYearFromUnix(UnixFromGps(week, time_of_week_s)); }

std::string IsoUtcFromUnix(double unix_s) { return IsoUtc(unix_s); }

double DecimalYearFromUnix(double unix_s) {
  const std::time_t t = static_cast<std::time_t>(std::floor(unix_s));
  std::tm tm{};
  gmtime_r(&t, &tm);
  const int64_t year = tm.tm_year + 1900;
  const double start = static_cast<double>(DaysFromCivil(year, 1, 1)) * 86400.0;
  const double end = static_cast<double>(DaysFromCivil(year + 1, 1, 1)) * 86400.0;
  return static_cast<double>(year) + (unix_s - start) / (end - start);
}

}  // namespace hexsim::logs
