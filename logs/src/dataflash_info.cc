// `hexsim info` on a DataFlash log: its message types and rates, text, parameters and damage.
#include <cmath>
#include <limits>
#include <map>

#include <fmt/format.h>

#include "dataflash_facts.h"
#include "dataflash_streams.h"
#include "hexsim/logs/dataflash_import.h"
#include "hexsim/logs/dataflash_plausibility.h"

namespace hexsim::logs {

using internal::DamageJson;
using internal::FirmwareOf;
using internal::GpsBootTime_s;
using internal::ParamsOfInterest;
using internal::Printable;

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}  // namespace

nlohmann::json DataFlashInfoJson(const std::string& bytes, const std::string& name) {
  struct TypeStats {
    size_t count = 0;
    double first_s = kNaN, last_s = kNaN;
  };
  std::map<std::string, TypeStats> stats;
  std::map<std::string, double> params;
  std::vector<std::string> texts;
  DataFlashReader reader(bytes);
  DataFlashMessage m;
  double t_min = kNaN, t_max = kNaN;
  RecordPlausibility plausibility;
  size_t data_messages = 0;
  while (reader.Next(&m)) {
    if (m.type() != kDataFlashFmtType) ++data_messages;
    if (!plausibility.Accept(m)) continue;
    TypeStats& s = stats[m.name()];
    ++s.count;
    const double t = m.name() == "GPS" ? GpsBootTime_s(m) : m.BootTime_s();
    if (std::isfinite(t)) {
      if (!std::isfinite(s.first_s)) s.first_s = t;
      s.last_s = t;
      if (m.name() == "ATT") {
        if (!std::isfinite(t_min)) t_min = t;
        t_max = t;
      }
    }
    if (m.name() == "PARM") {
      const std::string p = Printable(m.GetString("Name"));
      const double v = m.Get("Value");
      if (!p.empty() && std::isfinite(v)) params[p] = v;
    } else if (m.name() == "MSG" && texts.size() < 64) {
      texts.push_back(Printable(m.GetString("Message")));
    }
  }
  nlohmann::json j;
  j["schema"] = "hexsim.dataflash_info/1";
  j["source"] = name;
  j["bytes"] = bytes.size();
  j["firmware"] = FirmwareOf(texts);
  j["messages_text"] = texts;
  nlohmann::json types = nlohmann::json::array();
  for (const auto& [n, s] : stats) {
    nlohmann::json t{{"name", n}, {"count", s.count}};
    if (std::isfinite(s.first_s)) {
      t["first_s"] = s.first_s;
      t["last_s"] = s.last_s;
      if (s.count > 1 && s.last_s > s.first_s) t["rate_hz"] = static_cast<double>(s.count - 1) / (s.last_s - s.first_s);
    }
    types.push_back(t);
  }
  j["types"] = types;
  if (std::isfinite(t_min)) j["time"] = {{"start_s", t_min}, {"end_s", t_max}, {"duration_s", t_max - t_min}};
  j["params"] = ParamsOfInterest(params);
  j["parameter_count"] = params.size();
  j["damage"] = DamageJson(reader.damage());
  j["damage"].update(RecordDamageJson(plausibility.damage()));
  j["damage"]["damaged_record_share"] = DamagedRecordShare(reader.damage(), plausibility.damage(), data_messages);
  return j;
}

std::string DataFlashInfo(const std::string& bytes, const std::string& name) {
  const nlohmann::json j = DataFlashInfoJson(bytes, name);
  std::string out = fmt::format("{}: ArduPilot DataFlash, {} bytes\n", name, bytes.size());
  if (!j["firmware"].get<std::string>().empty()) out += fmt::format("firmware: {}\n", j["firmware"].get<std::string>());
  for (const auto& t : j["messages_text"]) out += fmt::format("  text: {}\n", t.get<std::string>());
  if (j.contains("time")) {
    out += fmt::format("time: {:.3f} .. {:.3f} s since boot ({:.1f} s, from ATT)\n", j["time"]["start_s"].get<double>(),
                       j["time"]["end_s"].get<double>(), j["time"]["duration_s"].get<double>());
  }
  out += fmt::format("{:<6} {:>8} {:>9}\n", "type", "count", "rate_Hz");
  for (const auto& t : j["types"]) {
    const std::string rate = t.contains("rate_hz") ? fmt::format("{:.2f}", t["rate_hz"].get<double>()) : "-";
    out += fmt::format("{:<6} {:>8} {:>9}\n", t["name"].get<std::string>(), t["count"].get<size_t>(), rate);
  }
  out += fmt::format("parameters: {} ({} of interest)\n", j["parameter_count"].get<size_t>(), j["params"].size());
  for (const auto& [k, v] : j["params"].items()) out += fmt::format("  {} = {}\n", k, v.get<double>());
  out += "damage:";
  for (const auto& [k, v] : j["damage"].items()) {
    if (v.is_number_unsigned()) out += fmt::format(" {}={}", k, v.get<size_t>());
  }
  out += fmt::format(" damaged_record_share={:.4f}\n", j["damage"]["damaged_record_share"].get<double>());
  for (const auto& [k, v] : j["damage"]["records_dropped_by_message"].items()) {
    out += fmt::format("  dropped {} records: {}\n", k, v.get<size_t>());
  }
  return out;
}

}  // namespace hexsim::logs
