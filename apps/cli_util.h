// Shared pieces of the hexsim command line: error reporting and exit codes (CONTRACTS.md).
#pragma once

#include <cstdio>
#include <string>

#include "hexsim/common/status.h"

namespace hexsim::app {

// CONTRACTS: interrupted by SIGINT/SIGTERM (batch, serve-px4).
constexpr int kExitInterrupted = 130;

// Prints "hexsim: <message>" on stderr (one line) and returns the status's exit code.
inline int Report(const Status& s) {
  if (s.ok()) return 0;
  std::string msg = s.message();
  for (char& c : msg) {
    if (c == '\n') c = ' ';
  }
  std::fprintf(stderr, "hexsim: %s\n", msg.c_str());
  return s.exit_code();
}

// The top level's last resort (apps/main.cc): an exception no command turned into a Status.
// One line on stderr; returns `exit_code`.
inline int ReportUnexpected(std::string what, int exit_code) {
  for (char& c : what) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  std::fprintf(stderr, "hexsim: unexpected error: %s\n", what.c_str());
  return exit_code;
}

}  // namespace hexsim::app
