// Builds small DataFlash byte streams for tests (FMT definitions and messages).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace hexsim::logs::testing {

class DataFlashWriter {
 public:
  // Appends a FMT message. `length` 0 = computed from the format chars.
  void Fmt(uint8_t type, const std::string& name, const std::string& format, const std::string& columns,
           int length = 0);
  // Appends a message whose payload is the given little-endian values, one per format char
  // (numbers for numeric chars, text for n/N/Z).
  void Msg(uint8_t type, const std::string& format, const std::vector<double>& values,
           const std::vector<std::string>& texts = {});
  void Raw(const std::string& bytes) { out_ += bytes; }
  const std::string& bytes() const { return out_; }

 private:
  std::string out_;
};

// The shared real log (ArduCopter 3.3 quad), read once.
const std::string& RealLogBytes();

}  // namespace hexsim::logs::testing
