#include "compass_map.h"

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "hexsim/logs/mag_input.h"
#include "replay_util.h"

namespace hexsim::gap::internal {
namespace {

constexpr size_t kMaxLogCompasses = 8;  // mag .. mag8, as the replay looks for them

// The log meta's external flag of the compass column `prefix`; nullopt when the meta does not say.
std::optional<bool> LogExternal(const nlohmann::json& meta, const std::string& prefix) {
  if (!meta.is_object() || !meta.contains("compasses") || !meta["compasses"].is_array()) return std::nullopt;
  for (const auto& c : meta["compasses"]) {
    if (!c.is_object() || c.value("column", std::string()) != prefix) continue;
    if (c.contains("external") && c["external"].is_boolean()) return c["external"].get<bool>();
  }
  return std::nullopt;
}

std::string KindWord(bool external) { return external ? "external" : "internal"; }

CompassMapping ByIndex(const std::vector<size_t>& log_compasses, const vehicle::VehicleParams& v, std::string why) {
  CompassMapping m;
  m.method = "index";
  m.why = std::move(why);
  for (size_t c : log_compasses) {
    if (c < v.compasses.size()) m.pairs.push_back({MagPrefix(c), static_cast<int>(c) + 1, v.compasses[c].external});
  }
  return m;
}

}  // namespace

CompassMapping MapCompasses(const logs::FlightLog& log, const vehicle::VehicleParams& v) {
  std::vector<size_t> log_compasses;
  for (size_t c = 0; c < kMaxLogCompasses; ++c) {
    if (ColumnHasData(log, MagPrefix(c) + "_x_uT")) log_compasses.push_back(c);
  }
  bool vehicle_says = false;
  for (const auto& cp : v.compasses) vehicle_says = vehicle_says || cp.external;
  if (!vehicle_says) {
    return ByIndex(log_compasses, v, fmt::format("the vehicle '{}' marks no compass external", v.name));
  }
  std::vector<bool> taken(v.compasses.size(), false);
  std::vector<std::pair<size_t, size_t>> chosen;  // log c, vehicle j
  std::string shared;                             // log compasses sharing a vehicle compass, said why
  for (size_t c : log_compasses) {
    const std::optional<bool> ext = LogExternal(log.meta, MagPrefix(c));
    if (!ext) return ByIndex(log_compasses, v, fmt::format("the log meta does not say whether {} is external", MagPrefix(c)));
    size_t j = v.compasses.size();
    if (c < v.compasses.size() && !taken[c] && v.compasses[c].external == *ext) j = c;
    for (size_t k = 0; k < v.compasses.size() && j == v.compasses.size(); ++k) {
      if (!taken[k] && v.compasses[k].external == *ext) j = k;
    }
    // More log compasses of a kind than the vehicle file has: the first of its kind stands for them
    // all (a second external compass on the mast is modelled as the file's external one is, never as
    // an internal one on the board, whose wiring field is another).
    for (size_t k = 0; k < v.compasses.size() && j == v.compasses.size(); ++k) {
      if (v.compasses[k].external == *ext) {
        j = k;
        shared += fmt::format("{}{} shares compass {} (the vehicle file's {} ones are taken)", shared.empty() ? "" : "; ",
                              MagPrefix(c), k + 1, KindWord(*ext));
      }
    }
    if (j == v.compasses.size()) {
      return ByIndex(log_compasses, v,
                     fmt::format("the vehicle '{}' has no {} compass for {}", v.name, KindWord(*ext), MagPrefix(c)));
    }
    taken[j] = true;
    chosen.emplace_back(c, j);
  }
  CompassMapping m;
  m.method = "external_flag";
  m.why = "the log meta and the vehicle file both say which compass is external" + (shared.empty() ? "" : "; " + shared);
  for (const auto& [c, j] : chosen) m.pairs.push_back({MagPrefix(c), static_cast<int>(j) + 1, v.compasses[j].external});
  return m;
}

vehicle::VehicleParams WithCompassesInLogOrder(const vehicle::VehicleParams& v, const CompassMapping& m) {
  if (m.method != "external_flag") return v;
  vehicle::VehicleParams out = v;
  const size_t n = v.compasses.size();
  std::vector<bool> slot_set(n, false), used(n, false);
  for (const CompassPair& p : m.pairs) {
    const size_t c = static_cast<size_t>(logs::CompassIndex(p.channel));
    const size_t j = static_cast<size_t>(p.vehicle_compass - 1);
    if (c >= n) continue;
    out.compasses[c] = v.compasses[j];
    slot_set[c] = used[j] = true;
  }
  size_t next = 0;
  for (size_t c = 0; c < n; ++c) {
    if (slot_set[c]) continue;
    while (next < n && used[next]) ++next;
    if (next < n) {
      out.compasses[c] = v.compasses[next];
      used[next] = true;
    }
  }
  return out;
}

}  // namespace hexsim::gap::internal
