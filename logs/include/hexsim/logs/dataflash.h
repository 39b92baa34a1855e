// A robust reader of ArduPilot's self-describing DataFlash (.bin) log format.
//
// A message is 0xA3 0x95, a type byte, then a payload laid out by the type's FMT message (type 128:
// Type, Length, Name, Format chars, Column labels). Newer logs add FMTU/MULT/UNIT (units and
// multipliers); older logs (ArduCopter 3.3) have none, so a built-in per-message scale table supplies
// them (see ScaleTableFor in dataflash.cc).
//
// The reader never trusts the file: it resynchronises on the next header after garbage, rejects FMT
// messages whose length disagrees with their format chars, accepts a message only when the next
// header (or the end of the file) follows it, and counts everything it skipped in DataFlashDamage.
// It never reads outside the buffer it was given.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace hexsim::logs {

inline constexpr uint8_t kDataFlashHead1 = 0xA3;
inline constexpr uint8_t kDataFlashHead2 = 0x95;
inline constexpr uint8_t kDataFlashFmtType = 128;
inline constexpr size_t kDataFlashFmtLength = 89;

// Size in bytes of one format char's value, or 0 for a char the format does not know.
size_t DataFlashFormatCharSize(char c);
// The standard scaling of a format char: c/C/e/E -> 0.01, L -> 1e-7, others 1.
double DataFlashFormatCharScale(char c);

// One message type, as defined by its FMT message (plus units/multipliers where known).
struct DataFlashFormat {
  uint8_t type = 0;
  size_t length = 0;  // whole message, header included
  std::string name;
  std::string format;               // one char per field
  std::vector<std::string> labels;  // one per field
  std::vector<size_t> offsets;      // payload offset of each field
  // Extra multiplier applied after the format char's own scale (FMTU/MULT or the scale table);
  // the decoded value is then in `units[i]` (empty when unknown).
  std::vector<double> multipliers;
  std::vector<std::string> units;
  // Index of the TimeUS / TimeMS field, or -1 (set when the format is read: BootTime_s is per message).
  int time_us_field = -1;
  int time_ms_field = -1;

  // Field index by label, or -1.
  int FieldIndex(std::string_view label) const;
};

// What could not be read. `skipped_bytes` totals every byte not part of an accepted message.
struct DataFlashDamage {
  size_t skipped_bytes = 0;          // all bytes outside accepted messages
  size_t bad_header_runs = 0;        // runs of bytes that did not start a header (garbage, flips)
  size_t unknown_type_messages = 0;  // a header whose type has no (valid) FMT
  size_t bad_formats = 0;            // FMT messages rejected: length/format/labels inconsistent
  size_t misaligned_messages = 0;    // a message not followed by a header: wrong length or damage
  size_t truncated_tail_bytes = 0;   // an incomplete message at the end of the file
  bool any() const { return skipped_bytes > 0 || bad_formats > 0; }
};

// A decoded view of one message. Valid until the reader's next Next() call.
class DataFlashMessage {
 public:
  const DataFlashFormat& format() const { return *format_; }
  const std::string& name() const { return format_->name; }
  uint8_t type() const { return format_->type; }
  size_t file_offset() const { return file_offset_; }

  bool Has(std::string_view label) const { return format_->FieldIndex(label) >= 0; }
  // Numeric value with the format char's scale and the field's multiplier applied. NaN for a
  // missing label or a text/array field.
  double Get(std::string_view label) const;
  double GetIndex(size_t field) const;
  // Raw integer (no scaling) of an integer field; 0 when absent or not an integer.
  int64_t GetRawInt(std::string_view label) const;
  // Text of an n/N/Z field, trailing NULs removed; empty when absent.
  std::string GetString(std::string_view label) const;
  // Time of the message in seconds since boot: TimeUS (µs) or TimeMS (ms); NaN if neither.
  // (GPS in old logs carries GPS time-of-week in TimeMS: see GpsBootTime_s in dataflash_import.)
  double BootTime_s() const;

 private:
  friend class DataFlashReader;
  int64_t RawIntAt(size_t field) const;
  const DataFlashFormat* format_ = nullptr;
  const uint8_t* payload_ = nullptr;  // format_->length - 3 bytes
  size_t file_offset_ = 0;
};

// Iterates the messages of a DataFlash byte buffer (not owned; must outlive the reader).
class DataFlashReader {
 public:
  explicit DataFlashReader(std::string_view bytes);

  // Advances to the next accepted message (FMT messages included). False at the end.
  bool Next(DataFlashMessage* message);

  const DataFlashDamage& damage() const { return damage_; }
  // Format by type or name; nullptr when not (yet) defined.
  const DataFlashFormat* FormatByType(uint8_t type) const;
  const DataFlashFormat* FormatByName(std::string_view name) const;
  // Bytes consumed so far (for progress).
  size_t position() const { return pos_; }

 private:
  bool HeaderAt(size_t pos) const;
  void Skip(size_t n);
  void HandleFmt(const uint8_t* payload);
  void HandleUnitMessage(const DataFlashFormat& fmt, const uint8_t* payload);
  void ApplyUnits(DataFlashFormat* fmt) const;

  std::string_view bytes_;
  size_t pos_ = 0;
  DataFlashDamage damage_;
  std::array<std::unique_ptr<DataFlashFormat>, 256> formats_;  // by type; null = undefined
  // Which types are FMTU/MULT/UNIT (decided once per FMT, not by name compares per message).
  enum class UnitKind : uint8_t { kNone, kFmtu, kMult, kUnit };
  std::array<UnitKind, 256> unit_kind_{};
  // FMTU/MULT/UNIT data (newer logs), filled only when the log has them.
  std::map<uint8_t, double> mult_by_id_;
  std::map<uint8_t, std::string> unit_by_id_;
  std::map<uint8_t, std::pair<std::string, std::string>> fmtu_;  // type -> unit ids, mult ids
};

}  // namespace hexsim::logs
