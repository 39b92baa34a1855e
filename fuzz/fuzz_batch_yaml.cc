// libFuzzer target: a batch file (hexsim batch BATCH.yaml) on arbitrary text. Every input ends in a
// BatchSpec or one bad-input line naming the file; never an exception, never a signal. A spec it
// accepts holds at most kMaxBatchRuns runs, and (when small enough to expand here) expands to exactly
// CountRuns of them, each with a 16-hex-digit id.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "hexsim/batch/batch_spec.h"
#include "hexsim/common/yaml_reader.h"

namespace {
constexpr double kExpandAtMost = 2000;  // runs expanded per input (keeps an execution fast)
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  auto bad = [](const hexsim::Status& s) {
    if (s.code() != hexsim::StatusCode::kBadInput || s.message().rfind("fuzz.yaml", 0) != 0) std::abort();
  };
  auto node = hexsim::YamlReader::LoadString(text, "fuzz.yaml");
  if (!node.ok()) {
    bad(node.status());
    return 0;
  }
  auto spec = hexsim::batch::ParseBatch(*node, "fuzz.yaml");
  if (!spec.ok()) {
    bad(spec.status());
    return 0;
  }
  const double runs = hexsim::batch::CountRuns(*spec);
  if (!(runs >= 0.0) || runs > static_cast<double>(hexsim::batch::kMaxBatchRuns)) std::abort();
  if (runs <= kExpandAtMost) {
    const auto points = hexsim::batch::ExpandBatch(*spec);
    if (static_cast<double>(points.size()) != runs) std::abort();
    for (const auto& p : points) {
      if (p.RunId().size() != 16) std::abort();
    }
  }
  return 0;
}
