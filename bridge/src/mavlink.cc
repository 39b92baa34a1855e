// MAVLink v2 framing (mavlink.h).
#include "hexsim/bridge/mavlink.h"

#include <cstdio>
#include <stdexcept>

namespace hexsim::bridge {

uint16_t CrcAccumulate(uint8_t byte, uint16_t crc) {
  uint8_t tmp = byte ^ static_cast<uint8_t>(crc & 0xFF);
  tmp ^= static_cast<uint8_t>(tmp << 4);
  return static_cast<uint16_t>((crc >> 8) ^ (tmp << 8) ^ (tmp << 3) ^ (tmp >> 4));
}

uint16_t Crc16Mcrf4xx(const uint8_t* data, size_t n, uint16_t crc) {
  for (size_t i = 0; i < n; ++i) crc = CrcAccumulate(data[i], crc);
  return crc;
}

namespace {
// CRC_EXTRA and lengths as mavgen derives them from message_definitions/v1.0/minimal.xml and
// common.xml of github.com/mavlink/mavlink at commit de1e078a3a7c53c9262a95b7417959a0f8bf4150
// (2026-07-22): CRC-16/MCRF4XX over "NAME " and, for each base field in wire order (sorted by type
// size, stable), "type name " plus the array length byte, folded to 8 bits (low ^ high). The test
// recomputes them from the field lists in messages.h.
constexpr MessageInfo kMessages[] = {
    {0, "HEARTBEAT", 50, 9, 9},
    {76, "COMMAND_LONG", 152, 33, 33},
    {93, "HIL_ACTUATOR_CONTROLS", 47, 81, 81},
    {107, "HIL_SENSOR", 108, 64, 65},
    {113, "HIL_GPS", 124, 36, 39},
    {115, "HIL_STATE_QUATERNION", 4, 64, 64},
    {147, "BATTERY_STATUS", 154, 36, 54},
};
}  // namespace

const MessageInfo* FindMessage(uint32_t id) {
  for (const MessageInfo& m : kMessages) {
    if (m.id == id) return &m;
  }
  return nullptr;
}

void FrameEncoder::Encode(uint32_t msgid, const uint8_t* payload, size_t len, std::vector<uint8_t>* out) {
  const MessageInfo* info = FindMessage(msgid);
  if (info == nullptr || len != info->max_len) {
    throw std::logic_error("FrameEncoder::Encode: message id or payload length not in the table");
  }
  size_t wire = len;
  while (wire > 1 && payload[wire - 1] == 0) --wire;  // v2 truncation keeps at least one byte
  const size_t start = out->size();
  out->push_back(kMavlinkV2Magic);
  out->push_back(static_cast<uint8_t>(wire));
  out->push_back(0);  // incompat_flags: unsigned
  out->push_back(0);  // compat_flags
  out->push_back(seq_++);
  out->push_back(sysid_);
  out->push_back(compid_);
  out->push_back(static_cast<uint8_t>(msgid & 0xFF));
  out->push_back(static_cast<uint8_t>((msgid >> 8) & 0xFF));
  out->push_back(static_cast<uint8_t>((msgid >> 16) & 0xFF));
  out->insert(out->end(), payload, payload + wire);
  uint16_t crc = Crc16Mcrf4xx(out->data() + start + 1, kMavlinkHeaderLen - 1 + wire);
  crc = CrcAccumulate(info->crc_extra, crc);
  out->push_back(static_cast<uint8_t>(crc & 0xFF));
  out->push_back(static_cast<uint8_t>(crc >> 8));
}

FrameParser::Outcome FrameParser::Push(uint8_t byte) {
  if (buf_.empty()) {
    if (byte != kMavlinkV2Magic) {
      ++stats_.skipped_bytes;
      return Outcome::kMore;
    }
    buf_.push_back(byte);
    return Outcome::kMore;
  }
  buf_.push_back(byte);
  const size_t n = buf_.size();
  if (n == 2) need_ = kMavlinkHeaderLen + buf_[1] + 2;
  if (n == 3 && buf_[2] != 0) {
    ++stats_.incompatible;
    return Outcome::kResync;
  }
  if (n == kMavlinkHeaderLen) {
    const uint32_t id = buf_[7] | (uint32_t{buf_[8]} << 8) | (uint32_t{buf_[9]} << 16);
    const MessageInfo* info = FindMessage(id);
    if (info == nullptr) {
      ++stats_.unknown_id;
      return Outcome::kResync;
    }
    if (buf_[1] > info->max_len) {
      ++stats_.too_long;
      return Outcome::kResync;
    }
  }
  if (n == need_) return TryFrame();
  return Outcome::kMore;
}

FrameParser::Outcome FrameParser::TryFrame() {
  const uint32_t id = buf_[7] | (uint32_t{buf_[8]} << 8) | (uint32_t{buf_[9]} << 16);
  const MessageInfo* info = FindMessage(id);  // known: checked at the header
  const size_t len = buf_[1];
  uint16_t crc = Crc16Mcrf4xx(buf_.data() + 1, kMavlinkHeaderLen - 1 + len);
  crc = CrcAccumulate(info->crc_extra, crc);
  const uint16_t got = static_cast<uint16_t>(buf_[kMavlinkHeaderLen + len] | (buf_[kMavlinkHeaderLen + len + 1] << 8));
  if (crc != got) {
    ++stats_.bad_crc;
    return Outcome::kResync;
  }
  frame_.seq = buf_[4];
  frame_.sysid = buf_[5];
  frame_.compid = buf_[6];
  frame_.msgid = id;
  frame_.wire_len = static_cast<uint8_t>(len);
  frame_.payload.fill(0);
  std::copy(buf_.begin() + kMavlinkHeaderLen, buf_.begin() + static_cast<std::ptrdiff_t>(kMavlinkHeaderLen + len),
            frame_.payload.begin());
  const uint32_t sender = (uint32_t{frame_.sysid} << 8) | frame_.compid;
  if (last_seq_ && sender == last_sender_) {
    stats_.lost_frames += static_cast<uint8_t>(frame_.seq - static_cast<uint8_t>(*last_seq_ + 1));
  }
  last_seq_ = frame_.seq;
  last_sender_ = sender;
  ++stats_.frames;
  buf_.clear();
  need_ = 0;
  return Outcome::kFrame;
}

void FrameParser::Resync(size_t at) {
  // The candidate's bytes after its magic may hold the start of a real frame: scan them again.
  in_.insert(in_.begin() + static_cast<std::ptrdiff_t>(at), buf_.begin() + 1, buf_.end());
  buf_.clear();
  need_ = 0;
}

std::string HexBytes(const std::vector<uint8_t>& bytes) {
  std::string s;
  char b[4];
  for (size_t i = 0; i < bytes.size(); ++i) {
    std::snprintf(b, sizeof b, i ? " %02x" : "%02x", bytes[i]);
    s += b;
  }
  return s;
}

}  // namespace hexsim::bridge
