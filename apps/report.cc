#include "report.h"

#include <fmt/format.h>

#include "hexsim/common/atomic_file.h"

namespace hexsim::app {

namespace {
std::string Escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<') o += "&lt;";
    else if (c == '>') o += "&gt;";
    else if (c == '&') o += "&amp;";
    else o += c;
  }
  return o;
}
}  // namespace

Status WriteCompareReport(const nlohmann::json& c, const std::string& out_dir) {
  std::string h = "<!doctype html><html><head><meta charset=\"utf-8\"><title>hexsim comparison</title></head><body>\n";
  h += fmt::format("<h1>{} on {} ({})</h1>\n", Escape(c.value("mission", "")), Escape(c.value("vehicle", "")),
                   Escape(c.value("world", "")));
  h += "<table border=1><tr><th>calibration</th><th>n</th><th>yaw max (deg)</th><th>yaw rms (deg)</th>"
       "<th>cross-track rms (m)</th></tr>\n";
  for (const auto& g : c["groups"]) {
    auto cell = [&](const char* k) {
      return g["metrics"].contains(k) ? fmt::format("{:.2f} ± {:.2f}", g["metrics"][k]["mean"].get<double>(),
                                                    g["metrics"][k]["std"].get<double>())
                                      : std::string("-");
    };
    h += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                     Escape(g["calibration"].get<std::string>()), g["n"].get<int>(), cell("yaw_error_deg.max"),
                     cell("yaw_error_deg.rms"), cell("cross_track_m.rms"));
  }
  h += "</table></body></html>\n";
  return WriteFileAtomic(out_dir + "/report.html", h);
}

}  // namespace hexsim::app
