#include "hexsim/common/paths.h"

#include <unistd.h>

#include <cstdlib>
#include <filesystem>

namespace hexsim {

namespace fs = std::filesystem;

const char* Version() { return HEXSIM_VERSION; }

std::string DataDir() {
  if (const char* env = std::getenv("HEXSIM_DATA_DIR"); env && *env) return env;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path share = exe.parent_path().parent_path() / "share" / "hexsim";
    if (fs::is_directory(share / "worlds", ec)) return share.string();
  }
  return HEXSIM_SOURCE_DIR;
}

Result<std::string> ResolveWorldFile(const std::string& kind, const std::string& name_or_path) {
  std::error_code ec;
  if (fs::is_regular_file(name_or_path, ec)) return name_or_path;
  const bool looks_like_path = name_or_path.find('/') != std::string::npos ||
                               (name_or_path.size() > 5 && name_or_path.substr(name_or_path.size() - 5) == ".yaml");
  if (!looks_like_path) {
    const fs::path p = fs::path(DataDir()) / "worlds" / kind / (name_or_path + ".yaml");
    if (fs::is_regular_file(p, ec)) return p.string();
    return Status::BadInput(name_or_path + ": no such " + kind.substr(0, kind.size() - 1) + " (looked in " +
                            (fs::path(DataDir()) / "worlds" / kind).string() + ")");
  }
  return Status::BadInput(name_or_path + ": cannot open file");
}

std::string DirName(const std::string& path) {
  const fs::path p = fs::path(path).parent_path();
  return p.empty() ? "." : p.string();
}

std::string FileStem(const std::string& path) { return fs::path(path).stem().string(); }

}  // namespace hexsim
