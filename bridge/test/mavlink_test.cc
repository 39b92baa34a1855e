// MAVLink v2 framing: CRC, CRC_EXTRA, truncation, sequence numbers, resynchronisation.
#include "hexsim/bridge/mavlink.h"

#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hexsim/bridge/messages.h"

namespace hexsim::bridge {
namespace {

// CRC-16/MCRF4XX's published check value: the CRC of the ASCII bytes "123456789" is 0x6F91.
TEST(Crc, MatchesTheCatalogueCheckValue) {
  const char* s = "123456789";
  EXPECT_EQ(Crc16Mcrf4xx(reinterpret_cast<const uint8_t*>(s), 9), 0x6F91);
}

// mavgen's CRC_EXTRA: X.25 over "NAME " and each base field's "type name " (+ array length byte) in
// wire order, folded to 8 bits. Recomputed here from the field lists of common.xml / minimal.xml.
uint8_t CrcExtra(const std::string& name, const std::vector<std::tuple<std::string, std::string, int>>& fields) {
  auto acc = [](const std::string& s, uint16_t crc) {
    return Crc16Mcrf4xx(reinterpret_cast<const uint8_t*>(s.data()), s.size(), crc);
  };
  uint16_t crc = acc(name + " ", 0xFFFF);
  for (const auto& [type, field, n] : fields) {
    crc = acc(type + " ", crc);
    crc = acc(field + " ", crc);
    if (n > 0) crc = CrcAccumulate(static_cast<uint8_t>(n), crc);
  }
  return static_cast<uint8_t>((crc & 0xFF) ^ (crc >> 8));
}

TEST(CrcExtra, TableAgreesWithTheFieldLists) {
  using F = std::vector<std::tuple<std::string, std::string, int>>;
  EXPECT_EQ(FindMessage(0)->crc_extra,
            CrcExtra("HEARTBEAT", F{{"uint32_t", "custom_mode", 0}, {"uint8_t", "type", 0}, {"uint8_t", "autopilot", 0},
                                    {"uint8_t", "base_mode", 0}, {"uint8_t", "system_status", 0},
                                    {"uint8_t", "mavlink_version", 0}}));
  EXPECT_EQ(FindMessage(93)->crc_extra,
            CrcExtra("HIL_ACTUATOR_CONTROLS", F{{"uint64_t", "time_usec", 0}, {"uint64_t", "flags", 0},
                                                {"float", "controls", 16}, {"uint8_t", "mode", 0}}));
  F sensor{{"uint64_t", "time_usec", 0}};
  for (const char* f : {"xacc", "yacc", "zacc", "xgyro", "ygyro", "zgyro", "xmag", "ymag", "zmag", "abs_pressure",
                        "diff_pressure", "pressure_alt", "temperature"}) {
    sensor.emplace_back("float", f, 0);
  }
  sensor.emplace_back("uint32_t", "fields_updated", 0);
  EXPECT_EQ(FindMessage(107)->crc_extra, CrcExtra("HIL_SENSOR", sensor));
  EXPECT_EQ(FindMessage(113)->crc_extra,
            CrcExtra("HIL_GPS", F{{"uint64_t", "time_usec", 0}, {"int32_t", "lat", 0}, {"int32_t", "lon", 0},
                                  {"int32_t", "alt", 0}, {"uint16_t", "eph", 0}, {"uint16_t", "epv", 0},
                                  {"uint16_t", "vel", 0}, {"int16_t", "vn", 0}, {"int16_t", "ve", 0},
                                  {"int16_t", "vd", 0}, {"uint16_t", "cog", 0}, {"uint8_t", "fix_type", 0},
                                  {"uint8_t", "satellites_visible", 0}}));
  EXPECT_EQ(FindMessage(115)->crc_extra,
            CrcExtra("HIL_STATE_QUATERNION",
                     F{{"uint64_t", "time_usec", 0}, {"float", "attitude_quaternion", 4}, {"float", "rollspeed", 0},
                       {"float", "pitchspeed", 0}, {"float", "yawspeed", 0}, {"int32_t", "lat", 0},
                       {"int32_t", "lon", 0}, {"int32_t", "alt", 0}, {"int16_t", "vx", 0}, {"int16_t", "vy", 0},
                       {"int16_t", "vz", 0}, {"uint16_t", "ind_airspeed", 0}, {"uint16_t", "true_airspeed", 0},
                       {"int16_t", "xacc", 0}, {"int16_t", "yacc", 0}, {"int16_t", "zacc", 0}}));
  EXPECT_EQ(FindMessage(147)->crc_extra,
            CrcExtra("BATTERY_STATUS", F{{"int32_t", "current_consumed", 0}, {"int32_t", "energy_consumed", 0},
                                         {"int16_t", "temperature", 0}, {"uint16_t", "voltages", 10},
                                         {"int16_t", "current_battery", 0}, {"uint8_t", "id", 0},
                                         {"uint8_t", "battery_function", 0}, {"uint8_t", "type", 0},
                                         {"int8_t", "battery_remaining", 0}}));
  EXPECT_EQ(FindMessage(76)->crc_extra,
            CrcExtra("COMMAND_LONG", F{{"float", "param1", 0}, {"float", "param2", 0}, {"float", "param3", 0},
                                       {"float", "param4", 0}, {"float", "param5", 0}, {"float", "param6", 0},
                                       {"float", "param7", 0}, {"uint16_t", "command", 0},
                                       {"uint8_t", "target_system", 0}, {"uint8_t", "target_component", 0},
                                       {"uint8_t", "confirmation", 0}}));
}

std::vector<Frame> ParseAll(FrameParser* p, const std::vector<uint8_t>& bytes) {
  std::vector<Frame> frames;
  p->Feed(bytes.data(), bytes.size(), [&](const Frame& f) { frames.push_back(f); });
  return frames;
}

// A heartbeat whose payload ends in zeros: the trailing zeros leave the wire, the receiver restores them.
TEST(Framing, TruncatesTrailingZerosAndRestoresThem) {
  FrameEncoder enc(1, 1);
  Heartbeat hb;
  hb.type = 2;
  hb.autopilot = 12;
  hb.mavlink_version = 0;  // the last two payload bytes are zero
  hb.system_status = 0;
  std::vector<uint8_t> bytes;
  EncodeMessage(&enc, kMsgHeartbeat, hb, &bytes);
  EXPECT_EQ(bytes[1], 6);  // 9 bytes less the three trailing zeros (base_mode too)
  EXPECT_EQ(bytes.size(), kMavlinkHeaderLen + 6 + 2);
  FrameParser p;
  auto frames = ParseAll(&p, bytes);
  ASSERT_EQ(frames.size(), 1u);
  const Heartbeat got = UnpackHeartbeat(frames[0]);
  EXPECT_EQ(got.type, 2);
  EXPECT_EQ(got.autopilot, 12);
  EXPECT_EQ(got.mavlink_version, 0);
}

TEST(Framing, AllZeroPayloadKeepsOneByte) {
  FrameEncoder enc(1, 1);
  Heartbeat hb;
  hb.mavlink_version = 0;
  std::vector<uint8_t> bytes;
  EncodeMessage(&enc, kMsgHeartbeat, hb, &bytes);
  EXPECT_EQ(bytes[1], 1);
  FrameParser p;
  EXPECT_EQ(ParseAll(&p, bytes).size(), 1u);
}

TEST(Framing, NumbersFramesAndCountsGaps) {
  FrameEncoder enc(1, 1);
  std::vector<uint8_t> a, b, c;
  EncodeMessage(&enc, kMsgHeartbeat, Heartbeat{}, &a);
  EncodeMessage(&enc, kMsgHeartbeat, Heartbeat{}, &b);  // lost on the way
  EncodeMessage(&enc, kMsgHeartbeat, Heartbeat{}, &c);
  EXPECT_EQ(a[4], 0);
  EXPECT_EQ(c[4], 2);
  FrameParser p;
  a.insert(a.end(), c.begin(), c.end());
  EXPECT_EQ(ParseAll(&p, a).size(), 2u);
  EXPECT_EQ(p.stats().lost_frames, 1u);
}

TEST(Framing, RefusesIncompatibleFlagsAndBadCrcThenResynchronises) {
  FrameEncoder enc(1, 1);
  HilActuatorControls m;
  m.time_usec = 123456;
  m.controls[0] = 0.5f;
  std::vector<uint8_t> good;
  EncodeMessage(&enc, kMsgHilActuatorControls, m, &good);
  std::vector<uint8_t> signed_frame = good;
  signed_frame[2] = 0x01;  // MAVLINK_IFLAG_SIGNED
  std::vector<uint8_t> bad_crc = good;
  bad_crc.back() ^= 0xFF;
  std::vector<uint8_t> stream = {0x00, 0xFD, 0x13, 0xFD};  // garbage, including stray magic bytes
  for (auto* part : {&signed_frame, &bad_crc, &good}) stream.insert(stream.end(), part->begin(), part->end());
  FrameParser p;
  auto frames = ParseAll(&p, stream);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(UnpackHilActuatorControls(frames[0]).time_usec, 123456u);
  EXPECT_EQ(UnpackHilActuatorControls(frames[0]).controls[0], 0.5f);
  EXPECT_GE(p.stats().incompatible, 1u);
  EXPECT_GE(p.stats().bad_crc, 1u);
}

TEST(Framing, UnknownIdIsSkippedAndTheNextFrameFound) {
  FrameEncoder enc(1, 1);
  std::vector<uint8_t> good;
  EncodeMessage(&enc, kMsgHeartbeat, Heartbeat{}, &good);
  std::vector<uint8_t> unknown = good;
  unknown[7] = 0x21;  // id 33 (GLOBAL_POSITION_INT): not in this bridge's table
  unknown.insert(unknown.end(), good.begin(), good.end());
  FrameParser p;
  EXPECT_EQ(ParseAll(&p, unknown).size(), 1u);
  EXPECT_EQ(p.stats().unknown_id, 1u);
}

TEST(Framing, ByteAtATimeEqualsAllAtOnceAndTruncatedInputWaits) {
  FrameEncoder enc(7, 9);
  HilSensor s;
  s.time_usec = 42;
  s.xmag = 0.21f;
  s.fields_updated = kHilMag;
  std::vector<uint8_t> bytes;
  EncodeMessage(&enc, kMsgHilSensor, s, &bytes);
  FrameParser p;
  int got = 0;
  for (size_t i = 0; i + 1 < bytes.size(); ++i) p.Feed(&bytes[i], 1, [&](const Frame&) { ++got; });
  EXPECT_EQ(got, 0);
  EXPECT_EQ(p.pending(), bytes.size() - 1);
  Frame last;
  p.Feed(&bytes.back(), 1, [&](const Frame& f) {
    ++got;
    last = f;
  });
  ASSERT_EQ(got, 1);
  EXPECT_EQ(last.sysid, 7);
  EXPECT_EQ(last.compid, 9);
  EXPECT_EQ(UnpackHilSensor(last).xmag, 0.21f);
}

}  // namespace
}  // namespace hexsim::bridge
