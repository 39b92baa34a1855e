#include "support/dataflash_writer.h"

#include <cstring>
#include <stdexcept>

#include "hexsim/common/atomic_file.h"
#include "hexsim/logs/dataflash.h"

namespace hexsim::logs::testing {

namespace {
template <class T>
void Put(std::string* out, T v) {
  char buf[sizeof(T)];
  std::memcpy(buf, &v, sizeof(T));
  out->append(buf, sizeof(T));
}
void PutText(std::string* out, const std::string& s, size_t n) {
  std::string t = s.substr(0, n);
  t.resize(n, '\0');
  *out += t;
}
}  // namespace

void DataFlashWriter::Fmt(uint8_t type, const std::string& name, const std::string& format,
                          const std::string& columns, int length) {
  size_t computed = 3;
  for (char c : format) computed += DataFlashFormatCharSize(c);
  out_ += static_cast<char>(kDataFlashHead1);
  out_ += static_cast<char>(kDataFlashHead2);
  out_ += static_cast<char>(kDataFlashFmtType);
  Put<uint8_t>(&out_, type);
  Put<uint8_t>(&out_, static_cast<uint8_t>(length > 0 ? static_cast<size_t>(length) : computed));
  PutText(&out_, name, 4);
  PutText(&out_, format, 16);
  PutText(&out_, columns, 64);
}

void DataFlashWriter::Msg(uint8_t type, const std::string& format, const std::vector<double>& values,
                          const std::vector<std::string>& texts) {
  out_ += static_cast<char>(kDataFlashHead1);
  out_ += static_cast<char>(kDataFlashHead2);
  out_ += static_cast<char>(type);
  size_t vi = 0, ti = 0;
  for (char c : format) {
    const double v = (c == 'n' || c == 'N' || c == 'Z') ? 0.0 : values.at(vi++);
    switch (c) {
      case 'b': Put<int8_t>(&out_, static_cast<int8_t>(v)); break;
      case 'B': case 'M': Put<uint8_t>(&out_, static_cast<uint8_t>(v)); break;
      case 'h': case 'c': Put<int16_t>(&out_, static_cast<int16_t>(v)); break;
      case 'H': case 'C': Put<uint16_t>(&out_, static_cast<uint16_t>(v)); break;
      case 'i': case 'e': case 'L': Put<int32_t>(&out_, static_cast<int32_t>(v)); break;
      case 'I': case 'E': Put<uint32_t>(&out_, static_cast<uint32_t>(v)); break;
      case 'f': Put<float>(&out_, static_cast<float>(v)); break;
      case 'd': Put<double>(&out_, v); break;
      case 'q': Put<int64_t>(&out_, static_cast<int64_t>(v)); break;
      case 'Q': Put<uint64_t>(&out_, static_cast<uint64_t>(v)); break;
      case 'n': PutText(&out_, texts.at(ti++), 4); break;
      case 'N': PutText(&out_, texts.at(ti++), 16); break;
      case 'Z': PutText(&out_, texts.at(ti++), 64); break;
      default: throw std::invalid_argument(std::string("format char ") + c);
    }
  }
}

const std::string& RealLogBytes() {
  static const std::string bytes = [] {
    auto r = ReadFile(std::string(HEXSIM_SOURCE_DIR) + "/data/real/ardupilot_copter_log171.bin");
    if (!r.ok()) throw std::runtime_error(r.status().message());
    return *r;
  }();
  return bytes;
}

}  // namespace hexsim::logs::testing
