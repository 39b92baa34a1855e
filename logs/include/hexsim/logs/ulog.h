// PX4 ULog (.ulg) reader, written from the public format description (docs.px4.io, "ULog File
// Format"): a 16-byte header ("ULog" 0x01 0x12 0x35, version, start time in µs), then messages
// {uint16 size, uint8 type, payload}: definitions (B flags, F formats "name:type field;...",
// I/M info, P/Q parameters) and data (A subscribe "multi_id msg_id name", D data "msg_id bytes",
// L/C log text, S sync, O dropout, R unsubscribe). Fields are packed in declaration order; a
// field's type is a basic type (int8_t … uint64_t, float, double, bool, char), or another format
// (nested), optionally an array "type[n]". Every topic record starts with uint64 timestamp (µs).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "hexsim/common/status.h"

namespace hexsim::logs {

// One flattened scalar field: "q[0]", "x", "accel.x" (nested), with its byte offset in a record.
struct ULogScalar {
  std::string name;
  std::string type;  // basic type
  size_t offset = 0;
};

struct ULogTopic {
  std::string name;  // e.g. "sensor_mag"
  int multi_id = 0;  // instance
  size_t record_size = 0;  // as the format declares it
  size_t logged_size = 0;  // without trailing padding, which PX4's logger does not write
  std::vector<ULogScalar> fields;
  std::vector<std::string> records;  // raw bytes, each record_size long, in file order

  // Numeric value of `field` in record `i` (NaN when missing).
  double Get(size_t i, std::string_view field) const;
  double TimeS(size_t i) const { return Get(i, "timestamp") * 1e-6; }
  // When record `i` was sampled: `timestamp_sample` where the message has one (PX4's sensor topics;
  // `timestamp` is when it was published, after filtering and averaging), else TimeS.
  double SampleTimeS(size_t i) const;
  bool Has(std::string_view field) const;
};

struct ULog {
  int version = 0;
  uint64_t start_us = 0;
  std::map<std::string, std::string> info;  // info key name → value (char arrays as text)
  std::map<std::string, double> params;     // last value of each parameter
  std::vector<ULogTopic> topics;            // one per subscription (name, multi_id)
  std::vector<std::string> messages;        // logged text
  size_t bytes_skipped = 0;                 // the truncated tail: a message cut by the file's end
  size_t bytes_damaged = 0;                 // bytes where no message started, skipped to a sync message
  size_t damaged_runs = 0;                  // how many such places
  size_t file_bytes = 0;                    // the whole file

  // The topic `name` with instance `multi_id`, or null.
  const ULogTopic* Find(std::string_view name, int multi_id = 0) const;
};

// True when `bytes` start with the ULog magic.
bool IsULog(std::string_view bytes);
// Bad input (kBadInput, naming `name`): no ULog magic, or no definitions before the data ends.
// Damage after a valid start is skipped: bytes where no message of a known type starts (or data of
// no subscription) up to the next sync message count in bytes_damaged (damaged_runs places), a
// message cut by the file's end in bytes_skipped.
Result<ULog> ParseULog(const std::string& bytes, const std::string& name);

// A human summary for `hexsim import --info LOG.ulg`: the system and release, the time span, each
// topic instance with its record count and mean rate, and the parameters a compass or current fit
// reads (CAL_MAG*, BAT*, CA_ROTOR_COUNT, SENS_*); damaged bytes where there are any.
std::string ULogInfo(const ULog& u, const std::string& name);

}  // namespace hexsim::logs
