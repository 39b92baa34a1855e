// Writes small ULog files for tests (the format of logs/include/hexsim/logs/ulog.h), so that the
// tests need no third-party log.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace hexsim::logs::testing {

class ULogWriter {
 public:
  ULogWriter();
  // "name:type field;type field;..." (F message).
  void Format(const std::string& definition);
  void Param(const std::string& name, float value);
  void ParamInt(const std::string& name, int32_t value);  // PX4's integer parameters (CAL_MAGn_ID, ROT)
  void Info(const std::string& key_type_name, const std::string& value);
  // Subscribes (A message) and returns the msg_id.
  uint16_t Subscribe(const std::string& topic, uint8_t multi_id);
  // One record (D message): the fields' bytes in order (use Pack).
  void Data(uint16_t msg_id, const std::string& record);
  // Raw message of any type.
  void Message(char type, const std::string& payload);
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
  uint16_t next_id_ = 0;
};

// Little-endian bytes of a value.
template <typename T>
std::string Pack(T v) {
  return std::string(reinterpret_cast<const char*>(&v), sizeof(T));
}

}  // namespace hexsim::logs::testing
