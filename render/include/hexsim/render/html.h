// Small helpers for the HTML reports that sit beside rendered figures.
#pragma once

#include <string>

namespace hexsim::render {

// Escapes <, >, & and " for HTML text and attribute values.
inline std::string HtmlEscape(const std::string& s) {
  std::string o;
  o.reserve(s.size());
  for (char c : s) {
    if (c == '<') o += "&lt;";
    else if (c == '>') o += "&gt;";
    else if (c == '&') o += "&amp;";
    else if (c == '"') o += "&quot;";
    else o += c;
  }
  return o;
}

}  // namespace hexsim::render
