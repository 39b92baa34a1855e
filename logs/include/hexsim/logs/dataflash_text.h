// ArduPilot's text DataFlash log (.log: what Mission Planner and MAVProxy write when they convert a
// .bin, and what older ground stations downloaded): one message per line, "NAME, v1, v2, ...", each
// type defined by an earlier "FMT, Type, Length, Name, Format, Columns" line. Values are written as
// the binary decodes them by its format char (c/C/e/E as value/100, L as degrees), integers as
// integers, text as text.
//
// The text is re-encoded as the binary log it was converted from (the same FMT types and format
// chars, each value back to its raw field), so one importer (dataflash_import.h) reads both forms and
// a text log imports as its .bin does. What cannot be read (a line whose type has no FMT yet, a
// value that is not a number where the format wants one, a truncated last line) is skipped and
// counted, never guessed.
#pragma once

#include <cstddef>
#include <string>

#include "hexsim/common/status.h"

namespace hexsim::logs {

// True when the bytes start (after an optional UTF-8 byte-order mark and whitespace) with a text
// FMT line: "FMT," followed by a number.
bool IsDataFlashText(const std::string& bytes);

struct DataFlashTextStats {
  size_t lines = 0;             // non-empty lines
  size_t messages = 0;          // lines re-encoded (FMT lines included)
  size_t unknown_type = 0;      // a data line whose name no FMT line defined before it
  size_t unreadable = 0;        // too few fields, or a field that is not a number where one is needed
  size_t bad_formats = 0;       // FMT lines with an unknown format char or an out-of-range type
  size_t skipped() const { return unknown_type + unreadable + bad_formats; }
};

// The binary DataFlash bytes of a text log. BadInput when no FMT line could be read.
Result<std::string> DataFlashTextToBinary(const std::string& text, const std::string& name,
                                          DataFlashTextStats* stats = nullptr);

// The binary bytes of a DataFlash log in either form: binary bytes are returned as they are, text is
// re-encoded (a note says so when `note` is given, with what was skipped).
Result<std::string> DataFlashBinaryBytes(const std::string& bytes, const std::string& name, std::string* note = nullptr);

}  // namespace hexsim::logs
