// The WMM Gauss coefficient tables, generated at build time from data/wmm/WMM*.COF
// (magnetics/cmake/generate_wmm.cmake). Private to the magnetics library.
#pragma once

namespace hexsim::magnetics::internal {

inline constexpr int kWmmMaxDegree = 12;
// Tables are indexed by n(n+1)/2 + m for 0 <= m <= n <= kWmmMaxDegree (the n = 0 entry is zero).
inline constexpr int kWmmCoefficientCount = (kWmmMaxDegree + 1) * (kWmmMaxDegree + 2) / 2;
inline constexpr int WmmIndex(int n, int m) { return n * (n + 1) / 2 + m; }

struct WmmCoefficients {
  int epoch = 0;                    // 2015, 2020, 2025
  double epoch_year = 0.0;          // decimal year of the coefficients
  const char* model = "";           // "WMM-2025"
  const char* release_date = "";    // as in the COF header
  const double* g_nT = nullptr;     // main field
  const double* h_nT = nullptr;
  const double* g_dot_nTpyr = nullptr;  // secular variation
  const double* h_dot_nTpyr = nullptr;
  const char* id = "";              // "wmm2015", "wmm2015v2", ...: the name users select
};

// All compiled-in models, ascending by epoch (for one epoch, the default model last); *count receives their number.
const WmmCoefficients* WmmTables(int* count);

}  // namespace hexsim::magnetics::internal
