#include "hexsim/logs/dataflash.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace hexsim::logs {

size_t DataFlashFormatCharSize(char c) {
  switch (c) {
    case 'b': case 'B': case 'M': return 1;
    case 'h': case 'H': case 'c': case 'C': case 'g': return 2;
    case 'i': case 'I': case 'e': case 'E': case 'L': case 'f': case 'n': return 4;
    case 'd': case 'q': case 'Q': return 8;
    case 'N': return 16;
    case 'Z': return 64;
    case 'a': return 64;  // int16_t[32]
    default: return 0;
  }
}

double DataFlashFormatCharScale(char c) {
  switch (c) {
    case 'c': case 'C': case 'e': case 'E': return 0.01;
    case 'L': return 1e-7;
    default: return 1.0;
  }
}

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

template <class T>
T Load(const uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));  // DataFlash is little-endian, as every host we build on.
  return v;
}

bool IsTextChar(char c) { return c == 'n' || c == 'N' || c == 'Z'; }

// IEEE 754 binary16 ('g', ArduPilot 4.5+): sign, 5 exponent bits (bias 15), 10 fraction bits.
double HalfToDouble(uint16_t h) {
  const double sign = (h & 0x8000u) != 0 ? -1.0 : 1.0;
  const int exponent = (h >> 10) & 0x1f;
  const double fraction = static_cast<double>(h & 0x3ffu);
  if (exponent == 0) return sign * std::ldexp(fraction, -24);  // subnormal: f·2^-10·2^-14
  if (exponent == 0x1f) return fraction == 0 ? sign * std::numeric_limits<double>::infinity() : kNaN;
  return sign * std::ldexp(1024.0 + fraction, exponent - 25);  // (1 + f·2^-10)·2^(e-15)
}

std::string FixedString(const uint8_t* p, size_t n) {
  size_t len = 0;
  while (len < n && p[len] != 0) ++len;
  return std::string(reinterpret_cast<const char*>(p), len);
}

// The fixed-size text field at p as a view, trailing NULs removed (no allocation).
std::string_view FixedView(const uint8_t* p, size_t n) {
  size_t len = 0;
  while (len < n && p[len] != 0) ++len;
  return {reinterpret_cast<const char*>(p), len};
}

std::vector<std::string> SplitLabels(std::string_view s) {
  std::vector<std::string> out;
  out.reserve(static_cast<size_t>(std::count(s.begin(), s.end(), ',')) + 1);
  size_t start = 0;
  while (start <= s.size()) {
    const size_t comma = s.find(',', start);
    const size_t end = comma == std::string_view::npos ? s.size() : comma;
    out.emplace_back(s.substr(start, end - start));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return out;
}

bool PrintableName(std::string_view s) {
  if (s.empty()) return false;
  for (char c : s) {
    if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) return false;
  }
  return true;
}

// Units and multipliers of fields in logs without FMTU (ArduCopter 3.x). The value after the format
// char's own scale is multiplied by `multiplier` to give `unit`, but only for a field whose format
// char is one of `formats`: a multiplier is a statement about how one firmware stored a number in an
// integer, and says nothing about the same label stored another way (ArduCopter 3.4 logs CURR Volt
// and Curr as floats already in V and A; 3.3 logs them as int16 hundredths).
struct ScaleEntry {
  const char* message;  // exact name, or a prefix ending in '*'
  const char* field;
  const char* formats;  // the format chars the entry was written for
  double multiplier;
  const char* unit;
};
// Format chars stored as plain integers with no scale of their own (DataFlash: b/B int8, h/H int16,
// i/I int32, q/Q int64, M flight mode). Only these take a multiplier from the table or from MULT.
constexpr bool IsRawIntegerChar(char c) {
  return c == 'b' || c == 'B' || c == 'h' || c == 'H' || c == 'i' || c == 'I' || c == 'q' || c == 'Q' || c == 'M';
}
constexpr ScaleEntry kScaleTable[] = {
    // CURR (3.2, 3.3, 3.4-dev): Volt and Curr as int16 hundredths, Vcc in mV, CurrTot float mAh.
    {"CURR", "Volt", "hH", 0.01, "V"},
    {"CURR", "Curr", "hH", 0.01, "A"},
    {"CURR", "Vcc", "hH", 0.001, "V"},
    {"CURR", "Volt2", "hH", 0.01, "V"},
    // CURR 3.4 (Qfff) and BAT/BATT: floats in V, A, mAh as logged.
    {"CURR", "Volt", "fd", 1.0, "V"},
    {"CURR", "Curr", "fd", 1.0, "A"},
    {"CURR", "CurrTot", "fd", 1.0, "mAh"},
    // MAG, MAG2, MAG3: milligauss counts.
    {"MAG*", "MagX", "hH", 0.001, "Gauss"},
    {"MAG*", "MagY", "hH", 0.001, "Gauss"},
    {"MAG*", "MagZ", "hH", 0.001, "Gauss"},
    {"MAG*", "OfsX", "hH", 0.001, "Gauss"},
    {"MAG*", "OfsY", "hH", 0.001, "Gauss"},
    {"MAG*", "OfsZ", "hH", 0.001, "Gauss"},
    {"MAG*", "MOfsX", "hH", 0.001, "Gauss"},
    {"MAG*", "MOfsY", "hH", 0.001, "Gauss"},
    {"MAG*", "MOfsZ", "hH", 0.001, "Gauss"},
    // Attitude ('c'/'C' already in degrees after the format scale).
    {"ATT", "Roll", "cCf", 1.0, "deg"},
    {"ATT", "Pitch", "cCf", 1.0, "deg"},
    {"ATT", "Yaw", "cCf", 1.0, "deg"},
    // GPS (3.3): Alt/RelAlt 'e' -> m, Spd 'E' -> m/s, GCrs 'e' -> deg, VZ float m/s (down).
    {"GPS", "Alt", "e", 1.0, "m"},
    {"GPS", "Alt", "i", 0.01, "m"},  // 3.4-3.6: int32 cm without FMTU
    {"GPS", "RelAlt", "e", 1.0, "m"},
    {"GPS", "RelAlt", "i", 0.01, "m"},
    {"GPS", "Spd", "E", 1.0, "m/s"},
    {"GPS", "Spd", "f", 1.0, "m/s"},
    {"GPS", "GCrs", "eEcCf", 1.0, "deg"},
    {"GPS", "VZ", "fe", 1.0, "m/s"},
    {"GPS", "Lat", "L", 1.0, "deg"},
    {"GPS", "Lng", "L", 1.0, "deg"},
    {"BARO", "Alt", "f", 1.0, "m"},
    {"IMU*", "GyrX", "f", 1.0, "rad/s"},
    {"IMU*", "GyrY", "f", 1.0, "rad/s"},
    {"IMU*", "GyrZ", "f", 1.0, "rad/s"},
    {"IMU*", "AccX", "f", 1.0, "m/s/s"},
    {"IMU*", "AccY", "f", 1.0, "m/s/s"},
    {"IMU*", "AccZ", "f", 1.0, "m/s/s"},
    {"IMU*", "Temp", "fcC", 1.0, "degC"},
};

// Every entry that scales names only raw integer chars (checked when compiled).
constexpr bool ScaleTableScalesOnlyIntegers() {
  for (const auto& e : kScaleTable) {
    if (e.multiplier == 1.0) continue;
    for (const char* c = e.formats; *c != 0; ++c) {
      if (!IsRawIntegerChar(*c)) return false;
    }
  }
  return true;
}
static_assert(ScaleTableScalesOnlyIntegers(), "a scale-table multiplier must name integer format chars only");

bool FormatListed(const char* formats, char c) {
  for (const char* p = formats; *p != 0; ++p) {
    if (*p == c) return true;
  }
  return false;
}

bool NameMatches(std::string_view pattern, std::string_view name) {
  // First char first: a FMT is checked against every entry, and most names differ there.
  if (pattern.empty() || name.empty() || pattern[0] != name[0]) return false;
  if (pattern.back() == '*') return name.substr(0, pattern.size() - 1) == pattern.substr(0, pattern.size() - 1);
  return name == pattern;
}

void ApplyScaleTable(DataFlashFormat* fmt) {
  for (const auto& e : kScaleTable) {
    if (!NameMatches(e.message, fmt->name)) continue;
    const int i = fmt->FieldIndex(e.field);
    if (i < 0) continue;
    if (!FormatListed(e.formats, fmt->format[static_cast<size_t>(i)])) continue;
    fmt->multipliers[static_cast<size_t>(i)] = e.multiplier;
    fmt->units[static_cast<size_t>(i)] = e.unit;
  }
}

}  // namespace

int DataFlashFormat::FieldIndex(std::string_view label) const {
  // Length and first char first: most labels differ there, and a memcmp per label is the hot spot
  // of the importer (and costly under the sanitizers).
  for (size_t i = 0; i < labels.size(); ++i) {
    const std::string& l = labels[i];
    if (l.size() == label.size() && (l.empty() || l[0] == label[0]) && std::string_view(l) == label) {
      return static_cast<int>(i);
    }
  }
  return -1;
}

double DataFlashMessage::GetIndex(size_t field) const {
  const size_t i = field;
  if (i >= format_->format.size()) return kNaN;
  const uint8_t* p = payload_ + format_->offsets[i];
  const char c = format_->format[i];
  double v = kNaN;
  switch (c) {
    case 'b': v = Load<int8_t>(p); break;
    case 'B': case 'M': v = Load<uint8_t>(p); break;
    case 'h': case 'c': v = Load<int16_t>(p); break;
    case 'H': case 'C': v = Load<uint16_t>(p); break;
    case 'i': case 'e': case 'L': v = Load<int32_t>(p); break;
    case 'I': case 'E': v = Load<uint32_t>(p); break;
    case 'f': v = Load<float>(p); break;
    case 'd': v = Load<double>(p); break;
    case 'g': v = HalfToDouble(Load<uint16_t>(p)); break;
    case 'q': v = static_cast<double>(Load<int64_t>(p)); break;
    case 'Q': v = static_cast<double>(Load<uint64_t>(p)); break;
    default: return kNaN;
  }
  return v * DataFlashFormatCharScale(c) * format_->multipliers[i];
}

double DataFlashMessage::Get(std::string_view label) const {
  const int i = format_->FieldIndex(label);
  return i < 0 ? kNaN : GetIndex(static_cast<size_t>(i));
}

int64_t DataFlashMessage::GetRawInt(std::string_view label) const {
  const int idx = format_->FieldIndex(label);
  return idx < 0 ? 0 : RawIntAt(static_cast<size_t>(idx));
}

int64_t DataFlashMessage::RawIntAt(size_t field) const {
  const size_t i = field;
  const uint8_t* p = payload_ + format_->offsets[i];
  switch (format_->format[i]) {
    case 'b': return Load<int8_t>(p);
    case 'B': case 'M': return Load<uint8_t>(p);
    case 'h': case 'c': return Load<int16_t>(p);
    case 'H': case 'C': return Load<uint16_t>(p);
    case 'i': case 'e': case 'L': return Load<int32_t>(p);
    case 'I': case 'E': return Load<uint32_t>(p);
    case 'q': return Load<int64_t>(p);
    case 'Q': return static_cast<int64_t>(Load<uint64_t>(p));
    default: return 0;
  }
}

std::string DataFlashMessage::GetString(std::string_view label) const {
  const int idx = format_->FieldIndex(label);
  if (idx < 0) return {};
  const size_t i = static_cast<size_t>(idx);
  const char c = format_->format[i];
  if (!IsTextChar(c)) return {};
  return FixedString(payload_ + format_->offsets[i], DataFlashFormatCharSize(c));
}

double DataFlashMessage::BootTime_s() const {
  if (format_->time_us_field >= 0) return static_cast<double>(RawIntAt(static_cast<size_t>(format_->time_us_field))) * 1e-6;
  if (format_->time_ms_field >= 0) return static_cast<double>(RawIntAt(static_cast<size_t>(format_->time_ms_field))) * 1e-3;
  return kNaN;
}

DataFlashReader::DataFlashReader(std::string_view bytes) : bytes_(bytes) {
  auto fmt = std::make_unique<DataFlashFormat>();
  fmt->type = kDataFlashFmtType;
  fmt->length = kDataFlashFmtLength;
  fmt->name = "FMT";
  fmt->format = "BBnNZ";
  fmt->labels = {"Type", "Length", "Name", "Format", "Columns"};
  fmt->offsets = {0, 1, 2, 6, 22};
  fmt->multipliers.assign(5, 1.0);
  fmt->units.assign(5, "");
  formats_[kDataFlashFmtType] = std::move(fmt);
}

const DataFlashFormat* DataFlashReader::FormatByType(uint8_t type) const { return formats_[type].get(); }

const DataFlashFormat* DataFlashReader::FormatByName(std::string_view name) const {
  for (const auto& f : formats_) {
    if (f && f->name == name) return f.get();
  }
  return nullptr;
}

bool DataFlashReader::HeaderAt(size_t pos) const {
  return pos + 1 < bytes_.size() && static_cast<uint8_t>(bytes_[pos]) == kDataFlashHead1 &&
         static_cast<uint8_t>(bytes_[pos + 1]) == kDataFlashHead2;
}

void DataFlashReader::Skip(size_t n) {
  pos_ += n;
  damage_.skipped_bytes += n;
}

void DataFlashReader::HandleFmt(const uint8_t* payload) {
  const uint8_t type = payload[0];
  const size_t length = payload[1];
  DataFlashFormat fmt;
  fmt.type = type;
  fmt.length = length;
  fmt.name = FixedView(payload + 2, 4);
  fmt.format = FixedView(payload + 6, 16);
  const std::string_view columns = FixedView(payload + 22, 64);
  if (!columns.empty()) fmt.labels = SplitLabels(columns);  // STRT-like messages have no fields
  size_t offset = 0;
  bool ok = PrintableName(fmt.name) && fmt.labels.size() == fmt.format.size();
  fmt.offsets.reserve(fmt.format.size());
  for (char c : fmt.format) {
    const size_t size = DataFlashFormatCharSize(c);
    if (size == 0) ok = false;
    fmt.offsets.push_back(offset);
    offset += size;
  }
  for (const auto& l : fmt.labels) ok = ok && PrintableName(l);
  // A FMT whose length disagrees with its format chars lies about one of them: trust neither.
  if (ok && length != offset + 3) ok = false;
  if (type == kDataFlashFmtType) {
    // Logs define FMT itself; accept only the layout we already use.
    if (!(ok && length == kDataFlashFmtLength && fmt.format == "BBnNZ")) ++damage_.bad_formats;
    return;
  }
  if (!ok) {
    ++damage_.bad_formats;
    return;
  }
  fmt.multipliers.assign(fmt.format.size(), 1.0);
  fmt.units.assign(fmt.format.size(), "");
  fmt.time_us_field = fmt.FieldIndex("TimeUS");
  fmt.time_ms_field = fmt.FieldIndex("TimeMS");
  unit_kind_[type] = fmt.name == "FMTU"   ? UnitKind::kFmtu
                     : fmt.name == "MULT" ? UnitKind::kMult
                     : fmt.name == "UNIT" ? UnitKind::kUnit
                                          : UnitKind::kNone;
  const bool has_fmtu = fmtu_.count(type) > 0;
  if (!has_fmtu) ApplyScaleTable(&fmt);
  formats_[type] = std::make_unique<DataFlashFormat>(std::move(fmt));
  if (has_fmtu) ApplyUnits(formats_[type].get());
}

void DataFlashReader::ApplyUnits(DataFlashFormat* fmt) const {
  const auto found = fmtu_.find(fmt->type);
  if (found == fmtu_.end()) return;
  const auto& [unit_ids, mult_ids] = found->second;
  for (size_t i = 0; i < fmt->format.size(); ++i) {
    const char c = fmt->format[i];
    if (i < unit_ids.size()) {
      const auto id = static_cast<uint8_t>(unit_ids[i]);
      const auto u = unit_by_id_.find(id);
      if (u != unit_by_id_.end() && !u->second.empty()) fmt->units[i] = u->second;
    }
    // A logged multiplier applies to raw integers only: c/C/e/E/L carry their own scale (the MULT
    // beside them restates it), and floats are stored in their unit (pymavlink's DFReader applies
    // no MULT to either).
    if (i < mult_ids.size() && IsRawIntegerChar(c)) {
      const auto id = static_cast<uint8_t>(mult_ids[i]);
      // '-' (0: no multiplier) and unknown ids leave the value as stored.
      const auto mu = mult_by_id_.find(id);
      if (mu != mult_by_id_.end() && mu->second != 0.0 && std::isfinite(mu->second)) {
        fmt->multipliers[i] = mu->second;
      }
    }
  }
}

void DataFlashReader::HandleUnitMessage(const DataFlashFormat& fmt, const uint8_t* payload) {
  DataFlashMessage m;
  m.format_ = &fmt;
  m.payload_ = payload;
  const UnitKind kind = unit_kind_[fmt.type];
  if (kind == UnitKind::kFmtu) {
    const int64_t type = m.GetRawInt("FmtType");
    if (type < 0 || type > 255 || type == kDataFlashFmtType) return;
    fmtu_[static_cast<uint8_t>(type)] = {m.GetString("UnitIds"), m.GetString("MultIds")};
    if (DataFlashFormat* target = formats_[static_cast<size_t>(type)].get()) {
      // FMTU supersedes the built-in scale table for this type.
      target->multipliers.assign(target->format.size(), 1.0);
      target->units.assign(target->format.size(), "");
      ApplyUnits(target);
    }
  } else if (kind == UnitKind::kMult) {
    const int64_t id = m.GetRawInt("Id");
    const double mult = m.Get("Mult");
    if (id < 0 || id > 255) return;
    mult_by_id_[static_cast<uint8_t>(id)] = mult;
  } else if (kind == UnitKind::kUnit) {
    const int64_t id = m.GetRawInt("Id");
    if (id < 0 || id > 255) return;
    unit_by_id_[static_cast<uint8_t>(id)] = m.GetString("Label");
  }
}

bool DataFlashReader::Next(DataFlashMessage* message) {
  const size_t size = bytes_.size();
  bool in_bad_run = false;
  while (pos_ < size) {
    if (!HeaderAt(pos_)) {
      if (pos_ + 1 >= size && static_cast<uint8_t>(bytes_[pos_]) == kDataFlashHead1) {
        damage_.truncated_tail_bytes += size - pos_;
      } else if (!in_bad_run) {
        ++damage_.bad_header_runs;
        in_bad_run = true;
      }
      Skip(1);
      continue;
    }
    if (pos_ + 3 > size) {  // a header with no type byte
      damage_.truncated_tail_bytes += size - pos_;
      Skip(size - pos_);
      break;
    }
    const uint8_t type = static_cast<uint8_t>(bytes_[pos_ + 2]);
    const DataFlashFormat* fmt_ptr = formats_[type].get();
    if (!fmt_ptr) {
      ++damage_.unknown_type_messages;
      Skip(1);
      continue;
    }
    const DataFlashFormat& fmt = *fmt_ptr;
    const size_t length = fmt.length;
    if (pos_ + length > size) {
      // Either a real message cut by the end of the file, or garbage that looks like a header.
      // Look for a later header before deciding.
      size_t next = pos_ + 1;
      while (next < size && !HeaderAt(next)) ++next;
      if (next >= size) {
        damage_.truncated_tail_bytes += size - pos_;
        Skip(size - pos_);
        break;
      }
      ++damage_.misaligned_messages;
      Skip(1);
      continue;
    }
    // Accept only when the next header (or the end of the file) follows: this catches a FMT that
    // lies about its length and headers that are really payload bytes.
    const size_t end = pos_ + length;
    if (end != size && !HeaderAt(end)) {
      // A message cut by the end of the file, one byte short of a header, is still good.
      const bool tail_fragment = end + 1 == size && static_cast<uint8_t>(bytes_[end]) == kDataFlashHead1;
      if (!tail_fragment) {
        ++damage_.misaligned_messages;
        Skip(1);
        continue;
      }
    }
    const uint8_t* payload = reinterpret_cast<const uint8_t*>(bytes_.data()) + pos_ + 3;
    const size_t offset = pos_;
    pos_ = end;
    if (type == kDataFlashFmtType) {
      HandleFmt(payload);
    } else if (unit_kind_[type] != UnitKind::kNone) {
      HandleUnitMessage(fmt, payload);
    }
    message->format_ = formats_[type].get();
    message->payload_ = payload;
    message->file_offset_ = offset;
    return true;
  }
  return false;
}

}  // namespace hexsim::logs
