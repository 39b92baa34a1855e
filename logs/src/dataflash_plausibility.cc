#include "hexsim/logs/dataflash_plausibility.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string_view>

#include <fmt/format.h>

namespace hexsim::logs {

namespace {

// A float this small but not zero is what random bytes in the exponent give; no sensor logs it.
constexpr double kSubnormal = 1e-30;

// How a field's decoded value is compared with its bound.
enum class Unit : uint8_t { kAsDecoded, kMilliGauss };

// One physical bound: `field` of the messages `message` names (exact, or the base of MAG/MAG2/...).
struct FieldBound {
  std::string_view message;
  std::string_view field;
  double lo, hi;
  Unit unit = Unit::kAsDecoded;
};

// The bounds, each far outside what the sensor can report (not tuned on any log):
//   ATT Roll ±200 deg, Pitch ±110 deg, Yaw -360..360 deg: the Euler angle domains (roll ±180, pitch
//     ±90; yaw 0..360 in 3.3 logs, ±180 later) with 20 deg of margin, because firmware wraps its
//     angles after rounding: an inverted ArduCopter 3.3 logs roll down to -181.2 deg.
//   IMU gyro ±70 rad/s: twice the ±2000 deg/s (34.9 rad/s) full scale of autopilot gyros (raw
//     counts reach further: a tumbling ArduCopter 3.3 logs 41.3 rad/s on IMU2, an L3GD20 at 70 mdps/digit).
//   IMU accel ±320 m/s^2: twice the ±16 g (157 m/s^2) full scale of autopilot accelerometers.
//   IMU temperature -60..150 degC: beyond the silicon's operating range (-40..105 degC).
//   MAG field and motor offsets ±16 G per axis: the full scale of the common autopilot compasses
//     (HMC5883 8 G, LSM303D 12 G, IST8310/LIS3MDL 16 G) and 25x the strongest Earth field (0.67 G).
//   CURR/BAT current -50..1000 A, voltage 0..120 V: beyond a 24S pack (100.8 V) and any hobby sensor.
//   RCOU 0..3000 us: servo pulses are 800..2200 us; 0 is "output off" (the record only when no channel
//   is plausible; one implausible channel is read as absent: IsPlausiblePwm_us in the header).
//   CTUN ThrOut 0..1000 (3.x), ThO 0..1: the throttle's own domain, with 10 % margin.
//   GPS Lat ±90, Lng ±180 deg; Spd 0..600 m/s, VZ ±600 m/s (above the COCOM 515 m/s limit);
//     Alt -1000..50000 m (receivers stop at 18 km for the same rule).
//   BARO Alt ±20000 m: the altitude relative to take-off of anything that hovers.
//   EKF PN/PE ±2e6 m, PD ±50000 m, VN/VE/VD ±600 m/s: beyond any multirotor's range, ceiling, speed.
constexpr double kMaxMag_mG = 16000.0;
constexpr FieldBound kBounds[] = {
    {"ATT", "Roll", -200, 200},      {"ATT", "Pitch", -110, 110},     {"ATT", "Yaw", -360, 360},
    {"IMU", "GyrX", -70, 70},        {"IMU", "GyrY", -70, 70},        {"IMU", "GyrZ", -70, 70},
    {"IMU", "AccX", -320, 320},      {"IMU", "AccY", -320, 320},      {"IMU", "AccZ", -320, 320},
    {"IMU", "Temp", -60, 150},       {"IMU", "T", -60, 150},
    {"MAG", "MagX", -kMaxMag_mG, kMaxMag_mG, Unit::kMilliGauss},
    {"MAG", "MagY", -kMaxMag_mG, kMaxMag_mG, Unit::kMilliGauss},
    {"MAG", "MagZ", -kMaxMag_mG, kMaxMag_mG, Unit::kMilliGauss},
    {"MAG", "MOfsX", -kMaxMag_mG, kMaxMag_mG, Unit::kMilliGauss},
    {"MAG", "MOfsY", -kMaxMag_mG, kMaxMag_mG, Unit::kMilliGauss},
    {"MAG", "MOfsZ", -kMaxMag_mG, kMaxMag_mG, Unit::kMilliGauss},
    {"MAG", "MOX", -kMaxMag_mG, kMaxMag_mG, Unit::kMilliGauss},
    {"MAG", "MOY", -kMaxMag_mG, kMaxMag_mG, Unit::kMilliGauss},
    {"MAG", "MOZ", -kMaxMag_mG, kMaxMag_mG, Unit::kMilliGauss},
    {"CURR", "Curr", -50, 1000},     {"CURR", "Volt", 0, 120},
    {"BAT", "Curr", -50, 1000},      {"BAT", "Volt", 0, 120},
    {"BATT", "Curr", -50, 1000},     {"BATT", "Volt", 0, 120},
    {"CTUN", "ThrOut", -100, 1100},  {"CTUN", "ThO", -0.1, 1.1},
    {"GPS", "Lat", -90, 90},         {"GPS", "Lng", -180, 180},       {"GPS", "Spd", 0, 600},
    {"GPS", "VZ", -600, 600},        {"GPS", "Alt", -1000, 50000},
    {"BARO", "Alt", -20000, 20000},
    {"EKF1", "PN", -2e6, 2e6},       {"EKF1", "PE", -2e6, 2e6},       {"EKF1", "PD", -5e4, 5e4},
    {"EKF1", "VN", -600, 600},       {"EKF1", "VE", -600, 600},       {"EKF1", "VD", -600, 600},
    {"NKF1", "PN", -2e6, 2e6},       {"NKF1", "PE", -2e6, 2e6},       {"NKF1", "PD", -5e4, 5e4},
    {"NKF1", "VN", -600, 600},       {"NKF1", "VE", -600, 600},       {"NKF1", "VD", -600, 600},
    {"XKF1", "PN", -2e6, 2e6},       {"XKF1", "PE", -2e6, 2e6},       {"XKF1", "PD", -5e4, 5e4},
    {"XKF1", "VN", -600, 600},       {"XKF1", "VE", -600, 600},       {"XKF1", "VD", -600, 600},
};

// MAG2 matches "MAG", IMU2 matches "IMU": a base name plus one instance digit.
bool NameMatches(std::string_view name, std::string_view base) {
  if (name == base) return true;
  return (base == "MAG" || base == "IMU") && name.size() == base.size() + 1 && name.substr(0, base.size()) == base &&
         name.back() >= '2' && name.back() <= '9';
}

bool IsFloatChar(char c) { return c == 'f' || c == 'd'; }

// ArduPilot logs a value it does not have as its own quiet NaN, AP_Logger::quiet_nanf() =
// nanf("0x4152") ("AR"), bits 0x7FC04152: a battery monitor without a current sensor writes it as
// BAT Curr, CurrTot and EnrgTot in every record (ArduCopter 4.x), and one with a sensor writes it
// until its first reading. The value is absent, not damage; random bytes hit this pattern with
// probability 2^-32 per field.
constexpr uint32_t kArduPilotNotAvailable = 0x7FC04152u;

bool IsArduPilotNotAvailable(char format_char, double v) {
  if (format_char != 'f' || !std::isnan(v)) return false;
  const auto f = static_cast<float>(v);  // a NaN keeps its payload through float -> double -> float
  uint32_t bits = 0;
  std::memcpy(&bits, &f, sizeof bits);
  return bits == kArduPilotNotAvailable;
}

// A float field whose bytes cannot be a logged number.
bool FloatContradictsType(double v) { return !std::isfinite(v) || (v != 0.0 && std::fabs(v) < kSubnormal); }

// Non-printable bytes before the terminating NUL (trailing NULs are padding).
bool TextContradictsType(const std::string& s) {
  for (const char ch : s) {
    if (ch < 0x20 || ch > 0x7e) return true;
  }
  return false;
}

double AsMilliGauss(const DataFlashMessage& m, size_t i, double v) {
  const std::string& unit = m.format().units[i];
  return unit == "Gauss" || unit == "G" ? v * 1000.0 : v;  // older logs: milligauss counts
}

enum class Verdict : uint8_t { kOk, kType, kRange };

Verdict CheckField(const DataFlashMessage& m, int index, double lo, double hi, Unit unit) {
  if (index < 0) return Verdict::kOk;
  const auto i = static_cast<size_t>(index);
  double v = m.GetIndex(i);
  if (IsArduPilotNotAvailable(m.format().format[i], v)) return Verdict::kOk;  // absent, read as NaN
  if (IsFloatChar(m.format().format[i]) && FloatContradictsType(v)) return Verdict::kType;
  if (!std::isfinite(v)) return Verdict::kType;
  if (unit == Unit::kMilliGauss) v = AsMilliGauss(m, i, v);
  return v < lo || v > hi ? Verdict::kRange : Verdict::kOk;
}

Verdict Check(const DataFlashMessage& m) {
  const std::string& name = m.name();
  if (name == "PARM") {
    const int i = m.format().FieldIndex("Value");
    if (i >= 0 && IsFloatChar(m.format().format[static_cast<size_t>(i)]) &&
        FloatContradictsType(m.GetIndex(static_cast<size_t>(i)))) {
      return Verdict::kType;
    }
    return TextContradictsType(m.GetString("Name")) ? Verdict::kType : Verdict::kOk;
  }
  if (name == "MSG") return TextContradictsType(m.GetString("Message")) ? Verdict::kType : Verdict::kOk;
  if (name == "RCOU") {
    // Range: only when no channel holds a plausible output (a single implausible channel is read as
    // absent by the importers, see IsPlausiblePwm_us).
    bool any_channel = false, any_plausible = false;
    for (size_t i = 0; i < m.format().format.size(); ++i) {
      const std::string& label = m.format().labels[i];
      if (label.empty() || label[0] != 'C') continue;  // C1..C14 or Ch1..Ch14
      const Verdict v = CheckField(m, static_cast<int>(i), 0, kMaxPwm_us, Unit::kAsDecoded);
      if (v == Verdict::kType) return v;
      any_channel = true;
      any_plausible = any_plausible || v == Verdict::kOk;
    }
    return any_channel && !any_plausible ? Verdict::kRange : Verdict::kOk;
  }
  Verdict worst = Verdict::kOk;
  for (const FieldBound& b : kBounds) {
    if (!NameMatches(name, b.message)) continue;
    const Verdict v = CheckField(m, m.format().FieldIndex(b.field), b.lo, b.hi, b.unit);
    if (v == Verdict::kType) return v;
    if (v == Verdict::kRange) worst = v;
  }
  return worst;
}

bool IsChecked(const std::string& name) {
  if (name == "PARM" || name == "MSG" || name == "RCOU") return true;
  for (const FieldBound& b : kBounds) {
    if (NameMatches(name, b.message)) return true;
  }
  return false;
}

// Records the reader lost: each rejected header (misaligned, unknown type) is one, and so is each run
// of garbage (a record whose header was damaged); a rejected record usually starts a garbage run, so
// the larger count is taken (a lower bound, not a sum that counts one record twice).
size_t LostRecords(const DataFlashDamage& reader) {
  return std::max(reader.misaligned_messages + reader.unknown_type_messages, reader.bad_header_runs);
}

}  // namespace

bool RecordPlausibility::Accept(const DataFlashMessage& m) {
  if (m.type() == kDataFlashFmtType || !IsChecked(m.name())) return true;
  ++damage_.checked;
  const Verdict v = Check(m);
  if (v == Verdict::kOk) return true;
  ++(v == Verdict::kType ? damage_.type : damage_.range);
  ++damage_.by_message[m.name()];
  return false;
}

double DamagedRecordShare(const DataFlashDamage& reader, const RecordDamage& records, size_t accepted_records) {
  const size_t lost = LostRecords(reader);
  const size_t damaged = lost + records.dropped();
  const size_t total = lost + accepted_records;
  return total == 0 ? 0.0 : static_cast<double>(damaged) / static_cast<double>(total);
}

nlohmann::json RecordDamageJson(const RecordDamage& records) {
  return {{"records_checked", records.checked},
          {"records_dropped_type", records.type},
          {"records_dropped_range", records.range},
          {"records_dropped_time", records.time},
          {"records_dropped_by_message", records.by_message}};
}

std::string DamageSummaryLine(const std::string& name, const DataFlashDamage& reader, const RecordDamage& records,
                              size_t accepted_records) {
  const size_t lost = LostRecords(reader);
  std::string by;
  for (const auto& [msg, n] : records.by_message) by += fmt::format("{}{} {}", by.empty() ? "" : ", ", msg, n);
  const double share = DamagedRecordShare(reader, records, accepted_records);
  return fmt::format(
      "{}: damaged log: {} % of records ({} of {}; refused above {:.0f} %): {} bytes skipped in {} garbage runs, "
      "{} records lost (misaligned {}, unknown type {}), dropped {} for type, {} for range{}, {} for time",
      name, 100.0 * share < 0.1 ? fmt::format("{:.2g}", 100.0 * share) : fmt::format("{:.1f}", 100.0 * share), lost + records.dropped(),
      lost + accepted_records, 100.0 * kMaxDamagedRecordShare, reader.skipped_bytes, reader.bad_header_runs, lost,
      reader.misaligned_messages,
      reader.unknown_type_messages, records.type, records.range, by.empty() ? "" : " (" + by + ")", records.time);
}

std::vector<std::string> DamageLines(const std::string& name, const DataFlashDamage& reader, const RecordDamage& records,
                                     size_t accepted_records) {
  std::vector<std::string> lines;
  if (reader.truncated_tail_bytes > 0) {
    lines.push_back(fmt::format("{}: truncated: the file ends inside a message ({} bytes of it, dropped); everything "
                                "before that imported",
                                name, reader.truncated_tail_bytes));
  }
  if (LostRecords(reader) + records.dropped() > 0) {
    lines.push_back(DamageSummaryLine(name, reader, records, accepted_records));
  }
  return lines;
}

}  // namespace hexsim::logs
