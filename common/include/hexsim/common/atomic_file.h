// Output that never looks finished before it is: write to a temporary name, then rename.
#pragma once

#include <string>
#include <string_view>

#include "hexsim/common/status.h"

namespace hexsim {

// Writes `content` to `path` via `path.tmp.<pid>` and an atomic rename.
Status WriteFileAtomic(const std::string& path, std::string_view content);

// Creates `dir` (and parents) if missing. `created` (optional) tells whether this call made it.
Status EnsureDirectory(const std::string& dir, bool* created = nullptr);

// An output directory for one command: created on Open(); if the command fails before Commit(),
// the destructor removes what this object created, so a failed command leaves nothing behind.
class OutputDirectory {
 public:
  OutputDirectory() = default;
  OutputDirectory(const OutputDirectory&) = delete;
  OutputDirectory& operator=(const OutputDirectory&) = delete;
  ~OutputDirectory();
  Status Open(const std::string& dir);
  void Commit() { committed_ = true; }
  const std::string& path() const { return dir_; }
  std::string File(const std::string& name) const { return dir_ + "/" + name; }

 private:
  std::string dir_;
  bool created_ = false;
  bool committed_ = false;
};

// Reads a whole file; a missing file is kBadInput naming it.
Result<std::string> ReadFile(const std::string& path);

}  // namespace hexsim
