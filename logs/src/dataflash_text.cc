#include "hexsim/logs/dataflash_text.h"

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "hexsim/logs/dataflash.h"

namespace hexsim::logs {
namespace {

struct TextFormat {
  uint8_t type = 0;
  std::string format;
};

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> SplitCommas(std::string_view line) {
  std::vector<std::string_view> out;
  size_t start = 0;
  for (size_t i = 0; i <= line.size(); ++i) {
    if (i == line.size() || line[i] == ',') {
      out.push_back(Trim(line.substr(start, i - start)));
      start = i + 1;
    }
  }
  return out;
}

bool IsText(char c) { return c == 'n' || c == 'N' || c == 'Z'; }

// A message or column name the binary reader accepts (letters, digits, '_').
bool ValidName(std::string_view s) {
  if (s.empty()) return false;
  for (char c : s) {
    if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) return false;
  }
  return true;
}

// A number as written: a decimal integer or a floating-point value (strtod's forms). False for
// anything else (empty, trailing characters, "nan" where the field is an integer).
bool ParseNumber(std::string_view s, double* v) {
  if (s.empty() || s.size() > 64) return false;
  char buf[65];
  std::memcpy(buf, s.data(), s.size());
  buf[s.size()] = '\0';
  char* end = nullptr;
  errno = 0;
  *v = std::strtod(buf, &end);
  return end == buf + s.size() && errno != ERANGE;
}

template <class T>
void Put(T v, std::string* out) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));  // DataFlash is little-endian, as every host we build on.
  out->append(b, sizeof(T));
}

// An integer field's raw value from its written (scaled) value: rounded to the nearest, refused when
// outside the field's type (a value the binary could not have held).
template <class T>
bool PutInteger(double raw, std::string* out) {
  if (!std::isfinite(raw)) return false;
  const double r = std::nearbyint(raw);
  // [lowest, 2^digits): both ends exact in a double (max() itself rounds up to 2^digits for 64 bits).
  const double end = std::ldexp(1.0, std::numeric_limits<T>::digits);
  if (r < static_cast<double>(std::numeric_limits<T>::lowest()) || r >= end) return false;
  Put(static_cast<T>(r), out);
  return true;
}

// IEEE 754 binary16 from a float (round to nearest even; overflow to infinity).
uint16_t HalfOf(float f) {
  uint32_t x;
  std::memcpy(&x, &f, 4);
  const uint32_t sign = (x >> 16) & 0x8000u;
  const int32_t exp = static_cast<int32_t>((x >> 23) & 0xff) - 127 + 15;
  uint32_t mant = x & 0x7fffffu;
  if (((x >> 23) & 0xff) == 0xff) return static_cast<uint16_t>(sign | 0x7c00u | (mant ? 0x200u : 0u));
  if (exp >= 31) return static_cast<uint16_t>(sign | 0x7c00u);
  if (exp <= 0) {
    if (exp < -10) return static_cast<uint16_t>(sign);
    mant |= 0x800000u;
    const uint32_t shift = static_cast<uint32_t>(14 - exp);
    uint32_t h = mant >> shift;
    const uint32_t rem = mant & ((1u << shift) - 1u), half = 1u << (shift - 1u);
    if (rem > half || (rem == half && (h & 1u))) ++h;
    return static_cast<uint16_t>(sign | h);
  }
  uint32_t h = (static_cast<uint32_t>(exp) << 10) | (mant >> 13);
  const uint32_t rem = mant & 0x1fffu;
  if (rem > 0x1000u || (rem == 0x1000u && (h & 1u))) ++h;
  return static_cast<uint16_t>(sign | h);
}

void PutText(std::string_view s, size_t size, std::string* out) {
  std::string field(size, '\0');
  std::memcpy(field.data(), s.data(), std::min(size, s.size()));
  out->append(field);
}

// One value of format char c, written as `s`, appended as the binary holds it.
bool PutValue(char c, std::string_view s, std::string* out) {
  if (IsText(c)) {
    PutText(s, DataFlashFormatCharSize(c), out);
    return true;
  }
  if (c == 'a') {  // int16_t[32]: written as "[v1 v2 ...]" or blank; read what is there, zeros after
    std::string field(64, '\0');
    size_t k = 0, i = 0;
    while (i < s.size() && k < 32) {
      while (i < s.size() && (s[i] == '[' || s[i] == ']' || s[i] == ' ' || s[i] == ';')) ++i;
      size_t j = i;
      while (j < s.size() && s[j] != ' ' && s[j] != ']' && s[j] != ';') ++j;
      double v = 0.0;
      if (j > i && ParseNumber(s.substr(i, j - i), &v) && std::fabs(v) <= 32767.0) {
        const auto h = static_cast<int16_t>(std::nearbyint(v));
        std::memcpy(field.data() + 2 * k++, &h, 2);
      }
      i = j + 1;
    }
    out->append(field);
    return true;
  }
  double v = 0.0;
  if (!ParseNumber(s, &v)) return false;
  // A float or half field the binary could not have held (a finite value beyond float's range).
  if ((c == 'f' || c == 'g') && std::isfinite(v) && std::fabs(v) > std::numeric_limits<float>::max()) return false;
  const double raw = v / DataFlashFormatCharScale(c);
  switch (c) {
    case 'b': return PutInteger<int8_t>(raw, out);
    case 'B': case 'M': return PutInteger<uint8_t>(raw, out);
    case 'h': case 'c': return PutInteger<int16_t>(raw, out);
    case 'H': case 'C': return PutInteger<uint16_t>(raw, out);
    case 'i': case 'e': case 'L': return PutInteger<int32_t>(raw, out);
    case 'I': case 'E': return PutInteger<uint32_t>(raw, out);
    case 'q': return PutInteger<int64_t>(raw, out);
    case 'Q': return PutInteger<uint64_t>(raw, out);
    case 'f': Put(static_cast<float>(v), out); return true;
    case 'd': Put(v, out); return true;
    case 'g': Put(HalfOf(static_cast<float>(v)), out); return true;
    default: return false;
  }
}

void PutHeader(uint8_t type, std::string* out) {
  out->push_back(static_cast<char>(kDataFlashHead1));
  out->push_back(static_cast<char>(kDataFlashHead2));
  out->push_back(static_cast<char>(type));
}

// "FMT, Type, Length, Name, Format, Col1,Col2,...": the columns hold commas of their own.
bool ReadFmt(const std::vector<std::string_view>& f, std::array<std::unique_ptr<TextFormat>, 256>* by_type,
             std::vector<std::pair<std::string, const TextFormat*>>* by_name, std::string* out) {
  if (f.size() < 6) return false;
  double type = 0.0;
  if (!ParseNumber(f[1], &type) || type < 0 || type > 255) return false;
  if (type == kDataFlashFmtType) return f[3] == "FMT";  // FMT's own definition: the reader knows it
  const std::string format(f[4]);
  size_t length = 3;
  for (char c : format) {
    const size_t n = DataFlashFormatCharSize(c);
    if (n == 0) return false;
    length += n;
  }
  if (length > 255 || !ValidName(f[3]) || f[3].size() > 4 || format.size() > 16) return false;
  // The columns as the binary reader checks them: one valid name per format char, in 64 bytes
  // (a FMT it would refuse is refused here, so its messages are counted, not written as damage).
  std::string columns;
  size_t labels = 0;
  for (size_t i = 5; i < f.size(); ++i) {
    if (format.empty() && f[i].empty() && f.size() == 6) break;  // a message without fields
    if (!ValidName(f[i])) return false;
    columns += (i > 5 ? "," : "") + std::string(f[i]);
    ++labels;
  }
  if (labels != format.size() || columns.size() > 64) return false;
  const auto t = static_cast<uint8_t>(type);
  auto fm = std::make_unique<TextFormat>();
  fm->type = t;
  fm->format = format;
  for (auto& [name, p] : *by_name) {
    if (p != nullptr && p->type == t) p = nullptr;  // the type is redefined: its old name no longer reads
  }
  by_name->emplace_back(std::string(f[3]), fm.get());
  (*by_type)[t] = std::move(fm);
  PutHeader(kDataFlashFmtType, out);
  out->push_back(static_cast<char>(t));
  out->push_back(static_cast<char>(length));
  PutText(f[3], 4, out);
  PutText(format, 16, out);
  PutText(columns, 64, out);
  return true;
}

const TextFormat* FindByName(const std::vector<std::pair<std::string, const TextFormat*>>& by_name, std::string_view n) {
  for (auto it = by_name.rbegin(); it != by_name.rend(); ++it) {
    if (it->first == n) return it->second;
  }
  return nullptr;
}

// A data line: its fields after the name, one per format char; a text field last in the format takes
// every comma after it (a message text may hold commas).
bool ReadData(const TextFormat& fm, const std::vector<std::string_view>& f, std::string_view line, std::string* out) {
  const size_t n = fm.format.size();
  if (f.size() - 1 < n) return false;
  std::string msg;
  PutHeader(fm.type, &msg);
  for (size_t k = 0; k < n; ++k) {
    std::string_view s = f[k + 1];
    if (k + 1 == n && IsText(fm.format[k]) && f.size() - 1 > n) {
      const size_t at = static_cast<size_t>(s.data() - line.data());
      s = Trim(line.substr(at));
    }
    double number = 0.0;
    if (fm.format[k] == 'M' && !ParseNumber(s, &number) && k + 1 < n) {
      // A flight mode written as its name ("AltHold"): ArduPilot's MODE messages carry the number
      // again in the next field (Mode, ModeNum), which the binary's Mode holds.
      s = f[k + 2];
    }
    if (!PutValue(fm.format[k], s, &msg)) return false;
  }
  if (f.size() - 1 > n && (n == 0 || !IsText(fm.format[n - 1]))) {
    if (!(n == 0 && f.size() == 2 && f[1].empty())) return false;  // "STRT, " with no fields
  }
  out->append(msg);
  return true;
}

size_t TextStart(const std::string& bytes) {
  size_t i = bytes.size() >= 3 && bytes.compare(0, 3, "\xEF\xBB\xBF") == 0 ? 3 : 0;
  while (i < bytes.size() && (bytes[i] == ' ' || bytes[i] == '\t' || bytes[i] == '\r' || bytes[i] == '\n')) ++i;
  return i;
}

}  // namespace

bool IsDataFlashText(const std::string& bytes) {
  const size_t i = TextStart(bytes);
  if (bytes.compare(i, 4, "FMT,") != 0) return false;
  size_t j = i + 4;
  while (j < bytes.size() && bytes[j] == ' ') ++j;
  return j < bytes.size() && bytes[j] >= '0' && bytes[j] <= '9';
}

Result<std::string> DataFlashTextToBinary(const std::string& text, const std::string& name, DataFlashTextStats* stats) {
  DataFlashTextStats st;
  std::array<std::unique_ptr<TextFormat>, 256> by_type;
  std::vector<std::pair<std::string, const TextFormat*>> by_name;
  std::string out;
  out.reserve(text.size() / 2);
  size_t fmts = 0;
  size_t pos = TextStart(text);
  while (pos < text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    const std::string_view line = Trim(std::string_view(text).substr(pos, end - pos));
    pos = end + 1;
    if (line.empty()) continue;
    ++st.lines;
    const std::vector<std::string_view> f = SplitCommas(line);
    if (f[0] == "FMT") {
      if (ReadFmt(f, &by_type, &by_name, &out)) {
        ++fmts;
        ++st.messages;
      } else {
        ++st.bad_formats;
      }
      continue;
    }
    const TextFormat* fm = FindByName(by_name, f[0]);
    if (fm == nullptr) {
      ++st.unknown_type;
      continue;
    }
    if (ReadData(*fm, f, line, &out)) {
      ++st.messages;
    } else {
      ++st.unreadable;
    }
  }
  if (stats != nullptr) *stats = st;
  if (fmts == 0) return Status::BadInput(fmt::format("{}: text DataFlash log: no readable FMT line", name));
  return out;
}

Result<std::string> DataFlashBinaryBytes(const std::string& bytes, const std::string& name, std::string* note) {
  if (!IsDataFlashText(bytes)) return bytes;
  DataFlashTextStats st;
  auto bin = DataFlashTextToBinary(bytes, name, &st);
  if (!bin.ok()) return bin.status();
  if (note != nullptr) {
    *note = fmt::format("{}: text DataFlash log: {} of {} lines read as messages", name, st.messages, st.lines);
    if (st.skipped() > 0) {
      *note += fmt::format(" ({} skipped: {} with no FMT before them, {} unreadable, {} bad FMT lines)", st.skipped(),
                           st.unknown_type, st.unreadable, st.bad_formats);
    }
  }
  return bin;
}

}  // namespace hexsim::logs
