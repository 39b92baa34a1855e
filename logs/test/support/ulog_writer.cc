#include "support/ulog_writer.h"

namespace hexsim::logs::testing {

ULogWriter::ULogWriter() {
  bytes_ = std::string("ULog\x01\x12\x35", 7);
  bytes_ += '\x01';                       // version
  bytes_ += Pack<uint64_t>(1000000);      // start time, µs
}

void ULogWriter::Message(char type, const std::string& payload) {
  bytes_ += Pack<uint16_t>(static_cast<uint16_t>(payload.size()));
  bytes_ += type;
  bytes_ += payload;
}

void ULogWriter::Format(const std::string& definition) { Message('F', definition); }

void ULogWriter::Param(const std::string& name, float value) {
  const std::string key = "float " + name;
  Message('P', std::string(1, static_cast<char>(key.size())) + key + Pack<float>(value));
}

void ULogWriter::ParamInt(const std::string& name, int32_t value) {
  const std::string key = "int32_t " + name;
  Message('P', std::string(1, static_cast<char>(key.size())) + key + Pack<int32_t>(value));
}

void ULogWriter::Info(const std::string& key_type_name, const std::string& value) {
  Message('I', std::string(1, static_cast<char>(key_type_name.size())) + key_type_name + value);
}

uint16_t ULogWriter::Subscribe(const std::string& topic, uint8_t multi_id) {
  const uint16_t id = next_id_++;
  Message('A', std::string(1, static_cast<char>(multi_id)) + Pack<uint16_t>(id) + topic);
  return id;
}

void ULogWriter::Data(uint16_t msg_id, const std::string& record) { Message('D', Pack<uint16_t>(msg_id) + record); }

}  // namespace hexsim::logs::testing
