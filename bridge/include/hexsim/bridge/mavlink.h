// MAVLink v2 framing, written here for the few messages the PX4 bridge needs (Debian 12 packages
// no MAVLink library). A v2 frame:
//
//   0xFD len incompat_flags compat_flags seq sysid compid msgid[3, little endian] payload[len] crc[2]
//
// crc = CRC-16/MCRF4XX (X.25: poly 0x1021 reflected, init 0xFFFF, no final xor) over every byte
// after the 0xFD magic, then over the message's CRC_EXTRA byte. The sender drops the payload's
// trailing zero bytes (at least one byte is kept); the receiver zero-fills up to the message's full
// length. Frames with incompatibility flags (signing, bit 0) are refused: this link is never signed.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace hexsim::bridge {

inline constexpr uint8_t kMavlinkV2Magic = 0xFD;
inline constexpr size_t kMavlinkHeaderLen = 10;  // magic .. msgid
inline constexpr size_t kMavlinkMaxPayload = 255;
inline constexpr size_t kMavlinkMaxFrame = kMavlinkHeaderLen + kMavlinkMaxPayload + 2;

// CRC-16/MCRF4XX, one byte at a time (MAVLink's crc_accumulate).
uint16_t CrcAccumulate(uint8_t byte, uint16_t crc);
uint16_t Crc16Mcrf4xx(const uint8_t* data, size_t n, uint16_t crc = 0xFFFF);

// What the framing needs to know of a message id.
struct MessageInfo {
  uint32_t id = 0;
  const char* name = "";
  uint8_t crc_extra = 0;
  uint8_t min_len = 0;  // base fields (the CRC_EXTRA covers them)
  uint8_t max_len = 0;  // with the extension fields
};
// The messages this bridge knows; nullptr for any other id.
const MessageInfo* FindMessage(uint32_t id);

// One decoded frame. `payload` is zero-filled to the message's max_len.
struct Frame {
  uint8_t seq = 0;
  uint8_t sysid = 0;
  uint8_t compid = 0;
  uint32_t msgid = 0;
  uint8_t wire_len = 0;  // the payload length on the wire (after truncation)
  std::array<uint8_t, kMavlinkMaxPayload> payload{};
};

// Frames payloads for one sender (system id, component id), numbering them 0, 1, ..., 255, 0, ...
class FrameEncoder {
 public:
  FrameEncoder(uint8_t sysid, uint8_t compid) : sysid_(sysid), compid_(compid) {}
  // Appends the frame of `len` payload bytes to *out (trailing zeros dropped). The id must be one
  // FindMessage knows and len its max_len (asserted).
  void Encode(uint32_t msgid, const uint8_t* payload, size_t len, std::vector<uint8_t>* out);
  uint8_t next_seq() const { return seq_; }
  void set_next_seq(uint8_t seq) { seq_ = seq; }

 private:
  uint8_t sysid_, compid_;
  uint8_t seq_ = 0;
};

// Counts of what the parser met; a frame is delivered only when every check passed.
struct ParserStats {
  uint64_t frames = 0;           // delivered
  uint64_t bad_crc = 0;
  uint64_t unknown_id = 0;       // well-formed, but an id FindMessage does not know: skipped
  uint64_t incompatible = 0;     // incompat_flags set (signed frames): refused
  uint64_t too_long = 0;         // payload longer than the message's max_len
  uint64_t skipped_bytes = 0;    // bytes dropped while looking for a magic byte
  uint64_t lost_frames = 0;      // gaps in the sender's sequence numbers
};

// Byte-stream parser. Feed it whatever the socket gave; it delivers whole frames and, after a bad
// frame, resynchronises on the next 0xFD after the bad frame's magic byte (so a frame hidden inside
// garbage is still found). Truncated input waits for more bytes.
class FrameParser {
 public:
  // Consumes bytes [data, data+n); calls on_frame(const Frame&) for each good frame.
  template <typename OnFrame>
  void Feed(const uint8_t* data, size_t n, OnFrame&& on_frame) {
    in_.assign(data, data + n);
    for (size_t i = 0; i < in_.size(); ++i) {
      const Outcome o = Push(in_[i]);
      if (o == Outcome::kFrame) on_frame(frame_);
      if (o == Outcome::kResync) Resync(i + 1);
    }
    in_.clear();
  }
  const ParserStats& stats() const { return stats_; }
  // Bytes held of an incomplete frame (a client that disconnects mid-frame leaves some).
  size_t pending() const { return buf_.size(); }

 private:
  enum class Outcome { kMore, kFrame, kResync };
  Outcome Push(uint8_t byte);
  Outcome TryFrame();     // buf_ holds a complete candidate: check and decode it
  void Resync(size_t at);  // drop the candidate's magic; rescan the rest of it before in_[at..]
  std::vector<uint8_t> in_;   // the bytes being fed (a rejected candidate's tail is put back here)
  std::vector<uint8_t> buf_;  // the candidate frame so far
  size_t need_ = 0;  // frame length once the header is in, else 0
  Frame frame_;
  ParserStats stats_;
  std::optional<uint8_t> last_seq_;
  uint32_t last_sender_ = 0;
};

// Hex text of bytes ("fd 09 00 ..."), for test messages.
std::string HexBytes(const std::vector<uint8_t>& bytes);

}  // namespace hexsim::bridge
