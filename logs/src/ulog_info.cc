// `hexsim import --info` for a PX4 ULog: what the log holds, before anything is imported.
#include <algorithm>
#include <string>

#include <fmt/format.h>

#include "hexsim/logs/ulog.h"

namespace hexsim::logs {
namespace {

// The parameters a compass, current or frame question reads first.
bool OfInterest(const std::string& p) {
  for (const char* prefix : {"CAL_MAG", "BAT", "CA_ROTOR_COUNT", "SENS_MAG", "SENS_BOARD", "SYS_AUTOSTART"}) {
    if (p.rfind(prefix, 0) == 0) return true;
  }
  return false;
}

}  // namespace

std::string ULogInfo(const ULog& u, const std::string& name) {
  std::string out = fmt::format("{}: PX4 ULog version {}\n", name, u.version);
  for (const char* key : {"sys_name", "ver_hw", "ver_sw", "ver_sw_release", "sys_uuid"}) {
    const auto it = u.info.find(key);
    if (it != u.info.end()) out += fmt::format("  {}: {}\n", key, it->second);
  }
  double t0 = 0.0, t1 = 0.0;
  bool any = false;
  for (const auto& t : u.topics) {
    if (t.records.empty()) continue;
    const double a = t.TimeS(0), b = t.TimeS(t.records.size() - 1);
    if (!any) t0 = a, t1 = b;
    t0 = std::min(t0, a);
    t1 = std::max(t1, b);
    any = true;
  }
  if (any) out += fmt::format("  time span: {:.1f} .. {:.1f} s ({:.1f} s)\n", t0, t1, t1 - t0);
  out += fmt::format("  topics ({}): instance, records, mean rate\n", u.topics.size());
  for (const auto& t : u.topics) {
    const size_t n = t.records.size();
    const double span = n > 1 ? t.TimeS(n - 1) - t.TimeS(0) : 0.0;
    const std::string rate = span > 0 ? fmt::format("{:.1f} Hz", static_cast<double>(n - 1) / span) : "-";
    out += fmt::format("    {}[{}]: {} records, {}\n", t.name, t.multi_id, n, rate);
  }
  std::string params;
  for (const auto& [p, v] : u.params) {
    if (OfInterest(p)) params += fmt::format("    {} = {:g}\n", p, v);
  }
  if (!params.empty()) out += "  parameters of interest:\n" + params;
  if (u.bytes_damaged > 0) {
    out += fmt::format("  damaged: {} bytes in {} places skipped to the next sync message\n", u.bytes_damaged,
                       u.damaged_runs);
  }
  if (u.bytes_skipped > 0) out += fmt::format("  truncated: the last {} bytes are a cut message\n", u.bytes_skipped);
  return out;
}

}  // namespace hexsim::logs
