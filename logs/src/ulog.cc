#include "hexsim/logs/ulog.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <set>
#include <string_view>

#include <fmt/format.h>

namespace hexsim::logs {
namespace {

constexpr char kMagic[7] = {'U', 'L', 'o', 'g', 0x01, 0x12, 0x35};
constexpr size_t kHeaderBytes = 16;
constexpr int kMaxNesting = 8;  // nested formats deeper than this are damage (PX4 uses 2–3)
// The sync message's magic: PX4's logger writes one every few kB, so that a reader can find the
// next message after damage.
constexpr char kSyncMagic[8] = {0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, static_cast<char>(0xBB), 0x12};
// The message types of the format (B F I M P Q A R D L C S O); no message of any type is empty.
bool IsMessageHeader(char type, size_t size) {
  return size > 0 && type != '\0' && std::string_view("BFIMPQARDLCSO").find(type) != std::string_view::npos;
}

// Little-endian reads from a byte buffer (ULog is little-endian).
template <typename T>
T Read(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

size_t BasicSize(const std::string& t) {
  if (t == "int8_t" || t == "uint8_t" || t == "bool" || t == "char") return 1;
  if (t == "int16_t" || t == "uint16_t") return 2;
  if (t == "int32_t" || t == "uint32_t" || t == "float") return 4;
  if (t == "int64_t" || t == "uint64_t" || t == "double") return 8;
  return 0;
}

double Decode(const std::string& t, const char* p) {
  if (t == "float") return Read<float>(p);
  if (t == "double") return Read<double>(p);
  if (t == "int8_t") return Read<int8_t>(p);
  if (t == "uint8_t" || t == "bool" || t == "char") return Read<uint8_t>(p);
  if (t == "int16_t") return Read<int16_t>(p);
  if (t == "uint16_t") return Read<uint16_t>(p);
  if (t == "int32_t") return Read<int32_t>(p);
  if (t == "uint32_t") return Read<uint32_t>(p);
  if (t == "int64_t") return static_cast<double>(Read<int64_t>(p));
  if (t == "uint64_t") return static_cast<double>(Read<uint64_t>(p));
  return std::numeric_limits<double>::quiet_NaN();
}

// "float[4] q" → type "float", count 4, name "q"; count 0 for a scalar. False when malformed.
bool SplitField(const std::string& decl, std::string* type, size_t* count, std::string* name) {
  const size_t sp = decl.find(' ');
  if (sp == std::string::npos || sp == 0 || sp + 1 >= decl.size()) return false;
  *type = decl.substr(0, sp);
  *name = decl.substr(sp + 1);
  *count = 0;
  const size_t br = type->find('[');
  if (br != std::string::npos) {
    if (type->back() != ']' || br + 2 > type->size() - 1) return false;
    const std::string n = type->substr(br + 1, type->size() - br - 2);
    if (n.empty() || n.size() > 5 || n.find_first_not_of("0123456789") != std::string::npos) return false;
    *count = static_cast<size_t>(std::stoul(n));
    *type = type->substr(0, br);
  }
  return true;
}

using Formats = std::map<std::string, std::vector<std::string>>;  // name → field declarations

// Flattens format `name` into scalars at `base`; false on an unknown type or too deep a nesting.
bool Flatten(const Formats& formats, const std::string& name, const std::string& prefix, size_t base, int depth,
             std::vector<ULogScalar>* out, size_t* size) {
  const auto it = formats.find(name);
  if (it == formats.end() || depth > kMaxNesting) return false;
  size_t off = 0;
  for (const auto& decl : it->second) {
    std::string type, field;
    size_t count = 0;
    if (!SplitField(decl, &type, &count, &field)) return false;
    const size_t n = count == 0 ? 1 : count;
    for (size_t k = 0; k < n; ++k) {
      const std::string full = prefix + field + (count == 0 ? "" : fmt::format("[{}]", k));
      if (const size_t bs = BasicSize(type)) {
        if (field.rfind("_padding", 0) != 0) out->push_back({full, type, base + off});
        off += bs;
      } else {
        size_t nested = 0;
        if (!Flatten(formats, type, full + ".", base + off, depth + 1, out, &nested)) return false;
        off += nested;
      }
      if (off > (1u << 16)) return false;  // a record fits one message (64 KiB): larger is damage
    }
  }
  *size = off;
  return true;
}

// "type name" key + value bytes → (name, value as text or number).
void ReadKeyValue(const char* p, size_t n, std::string* key_name, std::string* type, std::string* value) {
  if (n < 1) return;
  const size_t key_len = static_cast<uint8_t>(p[0]);
  if (1 + key_len > n) return;
  const std::string key(p + 1, key_len);
  size_t count = 0;
  if (!SplitField(key, type, &count, key_name)) return;
  value->assign(p + 1 + key_len, n - 1 - key_len);
}

}  // namespace

double ULogTopic::Get(size_t i, std::string_view field) const {
  if (i >= records.size()) return std::numeric_limits<double>::quiet_NaN();
  for (const auto& f : fields) {
    if (f.name == field) return Decode(f.type, records[i].data() + f.offset);
  }
  return std::numeric_limits<double>::quiet_NaN();
}

double ULogTopic::SampleTimeS(size_t i) const {
  const double sampled = Has("timestamp_sample") ? Get(i, "timestamp_sample") : 0.0;
  return sampled > 0 ? sampled * 1e-6 : TimeS(i);
}

bool ULogTopic::Has(std::string_view field) const {
  for (const auto& f : fields) {
    if (f.name == field) return true;
  }
  return false;
}

const ULogTopic* ULog::Find(std::string_view name, int multi_id) const {
  for (const auto& t : topics) {
    if (t.name == name && t.multi_id == multi_id) return &t;
  }
  return nullptr;
}

bool IsULog(std::string_view bytes) { return bytes.size() >= 7 && std::memcmp(bytes.data(), kMagic, 7) == 0; }

Result<ULog> ParseULog(const std::string& bytes, const std::string& name) {
  if (!IsULog(bytes)) return Status::BadInput(name + ": format: not a ULog file (no 'ULog' magic)");
  if (bytes.size() < kHeaderBytes) return Status::BadInput(name + ": format: ULog header truncated");
  ULog log;
  log.version = static_cast<uint8_t>(bytes[7]);
  log.start_us = Read<uint64_t>(bytes.data() + 8);
  log.file_bytes = bytes.size();
  Formats formats;
  std::map<uint16_t, size_t> by_msg_id;  // subscription → index in topics
  std::set<uint16_t> unread_ids;         // subscriptions whose format we cannot flatten
  size_t pos = kHeaderBytes;
  while (pos + 3 <= bytes.size()) {
    const size_t size = Read<uint16_t>(bytes.data() + pos);
    const char type = bytes[pos + 2];
    const bool orphan = type == 'D' && size >= 2 && by_msg_id.count(Read<uint16_t>(bytes.data() + pos + 3)) == 0 &&
                        unread_ids.count(Read<uint16_t>(bytes.data() + pos + 3)) == 0;
    if (!IsMessageHeader(type, size) || orphan || (type == 'D' && size < 2)) {
      // Damage: no message starts here (or data of no subscription). Resume at the next sync
      // message (its 3-byte header precedes the magic); without one the rest is lost.
      const size_t magic = bytes.find(std::string_view(kSyncMagic, sizeof kSyncMagic), pos + 4);
      const size_t resume = magic == std::string::npos ? bytes.size() : magic - 3;
      log.bytes_damaged += resume - pos;
      ++log.damaged_runs;
      pos = resume;
      continue;
    }
    if (pos + 3 + size > bytes.size()) break;  // truncated tail
    const char* p = bytes.data() + pos + 3;
    pos += 3 + size;
    switch (type) {
      case 'F': {
        const std::string text(p, size);
        const size_t colon = text.find(':');
        if (colon == std::string::npos || colon == 0) break;
        std::vector<std::string> fields;
        size_t start = colon + 1;
        while (start < text.size()) {
          size_t semi = text.find(';', start);
          if (semi == std::string::npos) semi = text.size();
          if (semi > start) fields.push_back(text.substr(start, semi - start));
          start = semi + 1;
        }
        formats[text.substr(0, colon)] = std::move(fields);
        break;
      }
      case 'I':
      case 'P': {
        std::string key, t, value;
        ReadKeyValue(p, size, &key, &t, &value);
        if (key.empty()) break;
        if (type == 'I') {
          const size_t bs = BasicSize(t);
          if (t == "char") log.info[key] = value;
          else if (bs > 0 && value.size() >= bs) log.info[key] = fmt::format("{}", Decode(t, value.data()));
        } else if ((t == "float" || t == "int32_t") && value.size() >= 4) {
          log.params[key] = Decode(t, value.data());
        }
        break;
      }
      case 'A': {
        if (size < 4) break;
        const int multi = static_cast<uint8_t>(p[0]);
        const uint16_t msg_id = Read<uint16_t>(p + 1);
        ULogTopic topic;
        topic.name.assign(p + 3, size - 3);
        topic.multi_id = multi;
        if (!Flatten(formats, topic.name, "", 0, 0, &topic.fields, &topic.record_size) || topic.record_size < 8) {
          unread_ids.insert(msg_id);
          break;
        }
        // PX4's logger drops a format's trailing padding from every record: a record may end
        // where its last real field ends.
        for (const auto& f : topic.fields) topic.logged_size = std::max(topic.logged_size, f.offset + BasicSize(f.type));
        by_msg_id[msg_id] = log.topics.size();
        log.topics.push_back(std::move(topic));
        break;
      }
      case 'D': {
        if (size < 2) break;
        const auto it = by_msg_id.find(Read<uint16_t>(p));
        if (it == by_msg_id.end()) break;  // a subscription we cannot read
        ULogTopic& t = log.topics[it->second];
        if (size - 2 < t.logged_size) break;  // short record: damage, skipped
        t.records.emplace_back(p + 2, std::min<size_t>(size - 2, t.record_size));
        t.records.back().resize(t.record_size, '\0');  // the dropped padding
        break;
      }
      case 'L':
        if (size > 9) log.messages.emplace_back(p + 9, size - 9);
        break;
      case 'C':
        if (size > 11) log.messages.emplace_back(p + 11, size - 11);
        break;
      default:  // B, M, Q, R, S, O and unknown types: nothing we need
        break;
    }
  }
  log.bytes_skipped = bytes.size() - std::min(pos, bytes.size());
  if (formats.empty()) return Status::BadInput(name + ": format: ULog file has no message formats");
  return log;
}

}  // namespace hexsim::logs
