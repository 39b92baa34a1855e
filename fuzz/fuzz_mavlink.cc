// libFuzzer target: the bridge's MAVLink v2 parser (bridge/src/mavlink.cc, messages.cc) on arbitrary
// bytes, as a client could send them. Each delivered frame is unpacked by its id and re-encoded with
// the same header: the re-encoded frame must parse back to the same payload (the CRC, CRC_EXTRA and
// truncation agree both ways), and the parser's counts must add up.
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "hexsim/bridge/messages.h"

namespace {
using namespace hexsim::bridge;

std::vector<uint8_t> Repack(const Frame& f) {
  switch (f.msgid) {
    case kMsgHeartbeat: return Pack(UnpackHeartbeat(f));
    case kMsgCommandLong: return Pack(UnpackCommandLong(f));
    case kMsgHilActuatorControls: return Pack(UnpackHilActuatorControls(f));
    case kMsgHilSensor: return Pack(UnpackHilSensor(f));
    case kMsgHilGps: return Pack(UnpackHilGps(f));
    case kMsgHilStateQuaternion: return Pack(UnpackHilStateQuaternion(f));
    case kMsgBatteryStatus: return Pack(UnpackBatteryStatus(f));
    default: std::abort();  // the parser delivers known ids only
  }
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FrameParser parser;
  uint64_t delivered = 0;
  parser.Feed(data, size, [&](const Frame& f) {
    ++delivered;
    const std::vector<uint8_t> payload = Repack(f);
    if (payload.size() != FindMessage(f.msgid)->max_len) std::abort();
    FrameEncoder enc(f.sysid, f.compid);
    enc.set_next_seq(f.seq);
    std::vector<uint8_t> bytes;
    enc.Encode(f.msgid, payload.data(), payload.size(), &bytes);
    FrameParser again;
    int n = 0;
    again.Feed(bytes.data(), bytes.size(), [&](const Frame& g) {
      ++n;
      if (g.msgid != f.msgid || g.payload != f.payload || g.seq != f.seq) std::abort();
    });
    if (n != 1) std::abort();
  });
  if (parser.stats().frames != delivered || parser.pending() > kMavlinkMaxFrame) std::abort();
  return 0;
}
