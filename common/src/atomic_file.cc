#include "hexsim/common/atomic_file.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

namespace hexsim {

namespace fs = std::filesystem;

Status WriteFileAtomic(const std::string& path, std::string_view content) {
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return Status::BadInput(path + ": cannot write file");
    out.write(content.data(), static_cast<std::streamsize>(content.size()));
    out.flush();
    if (!out) {
      std::remove(tmp.c_str());
      return Status::BadInput(path + ": write failed");
    }
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    std::remove(tmp.c_str());
    return Status::BadInput(path + ": cannot rename into place: " + ec.message());
  }
  return Status::Ok();
}

Status EnsureDirectory(const std::string& dir, bool* created) {
  std::error_code ec;
  const bool existed = fs::is_directory(dir, ec);
  if (!existed) {
    fs::create_directories(dir, ec);
    if (ec) return Status::BadInput(dir + ": cannot create directory: " + ec.message());
  }
  if (created) *created = !existed;
  return Status::Ok();
}

OutputDirectory::~OutputDirectory() {
  if (created_ && !committed_) {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
}

Status OutputDirectory::Open(const std::string& dir) {
  dir_ = dir;
  return EnsureDirectory(dir, &created_);
}

Result<std::string> ReadFile(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return Status::BadInput(path + ": is a directory, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::BadInput(path + ": cannot open file");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace hexsim
