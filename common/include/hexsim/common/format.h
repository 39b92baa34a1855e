// Text formatting for the core libraries, which use the standard library only (fmt is for the
// *_io targets): printf-style Format, fmt's "{}" for a double, and Join.
#pragma once

#include <string>
#include <vector>

namespace hexsim {

// printf into a std::string: Format("%s: %zu samples", name.c_str(), n).
std::string Format(const char* format, ...) __attribute__((format(printf, 1, 2)));

// A double as fmt's "{}" prints it: the shortest decimal that reads back to the same value, in
// fixed notation for decimal exponents -4..15 ("0.0001", "1234.5", "100000") and exponent notation
// otherwise ("1e-05", "1.5e+16"); "inf", "-inf", "nan".
std::string ShortestDouble(double v);

// "a, b, c" for Join({"a", "b", "c"}, ", ").
std::string Join(const std::vector<std::string>& items, const std::string& separator);

}  // namespace hexsim
