// THE plausibility table (CONTRACTS.md, real data): every quantity that the gap diagnosis, the
// identification or the calibration estimates from a real log has one entry here, with its unit,
// the range a physical aircraft can produce, and the one-line physical reason for that range. It lives
// in common/ (needs only the standard library) so that magnetics, identify, realdata and gap all read
// the same rows. A fit outside `lo..hi` is "implausible: model mismatch", never a finding. Nuisance
// terms also carry a normal range (`normal_lo..normal_hi`): inside it nothing needs doing; outside it
// (but plausible) the term is a finding the user acts on (e.g. recalibrate).
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace hexsim::plausibility {

struct PhysicalRange {
  std::string name;  // effect or parameter name (CONTRACTS effect names, timing and nuisance terms)
  std::string unit;  // the unit of the magnitude the consumers report
  double lo = 0.0, hi = 0.0;                // physically possible
  double normal_lo = 0.0, normal_hi = 0.0;  // nothing to act on (equal to lo..hi for effects)
  std::string reason;                       // one line: why these bounds
};

// Every entry (effects, nuisance terms, timing terms, dynamics parameters).
const std::vector<PhysicalRange>& PlausibilityTable();
// The entry for `name`, or null.
const PhysicalRange* FindRange(std::string_view name);
// value inside [lo, hi]; a name without an entry is plausible (nothing is known against it).
bool IsPlausible(std::string_view name, double value);
// An estimate with its 95 % interval [ci_lo, ci_hi] is a model mismatch only when the whole
// interval lies outside [lo, hi]: one that overlaps the range (a latency of −5 ms [−18, 52]) is an
// estimate the data cannot tell from a physical value. False for a name without an entry only when
// the interval is not finite.
bool IntervalPlausible(std::string_view name, double ci_lo, double ci_hi);
// value inside [normal_lo, normal_hi] (true for a name without an entry).
bool IsNormal(std::string_view name, double value);
// "lo..hi unit" for reports.
std::string RangeText(std::string_view name);

}  // namespace hexsim::plausibility
