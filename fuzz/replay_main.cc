// Runs a libFuzzer target's LLVMFuzzerTestOneInput on files without libFuzzer (any compiler): each
// argument is a file or a directory of files (its seeds). Exit 0 when every input ran; a finding
// aborts or throws as under the fuzzer.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv);
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

namespace {

int RunFile(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) {
    std::fprintf(stderr, "replay: %s: cannot read\n", p.c_str());
    return 1;
  }
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  LLVMFuzzerTestOneInput(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  LLVMFuzzerInitialize(&argc, &argv);
  int failed = 0, ran = 0;
  for (int i = 1; i < argc; ++i) {
    const std::filesystem::path arg(argv[i]);
    std::error_code ec;
    if (std::filesystem::is_directory(arg, ec)) {
      std::vector<std::filesystem::path> files;
      for (const auto& e : std::filesystem::directory_iterator(arg, ec)) files.push_back(e.path());
      std::sort(files.begin(), files.end());
      for (const auto& f : files) failed += RunFile(f), ++ran;
    } else {
      failed += RunFile(arg), ++ran;
    }
  }
  std::fprintf(stderr, "replay: %d input(s), %d unreadable\n", ran, failed);
  return failed == 0 && ran > 0 ? 0 : 1;
}
