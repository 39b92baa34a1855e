// Record plausibility for the DataFlash importer: damage must never create columns or values.
//
// A byte changed inside a message's payload keeps the framing intact, so the reader (dataflash.h)
// accepts the message; only its values can tell. A record the importer reads is dropped, and counted,
// when
//   type   a field it reads holds what its FMT type cannot mean: a float (f, d) that is NaN, infinite
//          or subnormal (|x| < 1e-30, x != 0: random bytes in the exponent), or a text field (PARM
//          Name, MSG Message) with non-printable bytes before its terminating NUL;
//   range  a value lies far outside what the sensor can report (table in dataflash_plausibility.cc,
//          each bound with its physical reason);
//   time   a channel's sample time steps back, or spikes forward past its next two samples
//          (Channel::Finalize in dataflash_import.cc; tolerance zero: one message type's TimeUS never
//          decreases in an undamaged log).
// The share of damaged records is damaged / (lost + accepted), where damaged counts these drops plus
// the records the reader lost (the larger of: rejected headers, i.e. misaligned or unknown type; and
// runs of garbage, i.e. damaged headers). Above
// kMaxDamagedRecordShare the import is refused (bad input, exit 2): the rest can no longer be trusted.
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hexsim/logs/dataflash.h"

namespace hexsim::logs {

// More than a fifth of the records damaged: refused. Physical reading: a log losing one record in five
// has lost at least one sample in five of every sensor it records, beyond what the channels' own
// sample-and-hold can bridge without the held values standing for more time than they were valid.
inline constexpr double kMaxDamagedRecordShare = 0.20;

// An RCOU channel value a servo output can hold: 0 ("output off") to 3000 us (pulses are 800-2200 us).
// A value outside is that channel's, not the record's: some boards log unused channels as garbage
// that never changes (e.g. the PXF cape logs C5..C12 as -8047, -27794, ...), so the importers read such
// a value as absent (NaN) and keep the record; a record is dropped only when no channel is plausible.
inline constexpr double kMaxPwm_us = 3000.0;
inline bool IsPlausiblePwm_us(double pwm_us) { return pwm_us >= 0.0 && pwm_us <= kMaxPwm_us; }

struct RecordDamage {
  size_t checked = 0;  // records of the types the importer reads
  size_t type = 0;     // dropped: a value its FMT type cannot mean
  size_t range = 0;    // dropped: a value far outside the sensor's range
  size_t time = 0;     // dropped: damaged sample time (filled in by the importer)
  std::map<std::string, size_t> by_message;  // dropped records per message name (type and range)
  size_t dropped() const { return type + range + time; }
};

// Checks records one by one (FMT messages and types the importer does not read always pass).
class RecordPlausibility {
 public:
  // True when `m` may be used; otherwise counts why and returns false.
  bool Accept(const DataFlashMessage& m);
  const RecordDamage& damage() const { return damage_; }
  RecordDamage& mutable_damage() { return damage_; }

 private:
  RecordDamage damage_;
};

// Records lost or dropped, over all records the file held: 0..1.
double DamagedRecordShare(const DataFlashDamage& reader, const RecordDamage& records, size_t accepted_records);
// The counts as JSON (added to the meta's and --info's "damage").
nlohmann::json RecordDamageJson(const RecordDamage& records);
// One line for stderr: "NAME: damaged log: 1.2 % of records (412 of 34811): 3 garbage runs, ...".
std::string DamageSummaryLine(const std::string& name, const DataFlashDamage& reader, const RecordDamage& records,
                              size_t accepted_records);
// What a command says about damage that did not refuse the log, one line each, nothing for a clean
// log: "NAME: truncated: ..." when the file ends inside a message, and the summary line above when
// records were lost or dropped. (A FMT the reader rejected costs no line by itself: its messages,
// if any, are counted as lost.)
std::vector<std::string> DamageLines(const std::string& name, const DataFlashDamage& reader, const RecordDamage& records,
                                     size_t accepted_records);

}  // namespace hexsim::logs
