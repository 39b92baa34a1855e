// hexsim.gap_selftest/1 (CONTRACTS.md): the typed selftest result serialised, and a
// trial record to and from JSON for a runner that passes records between processes (selftest_json.cc).
#pragma once

#include <nlohmann/json.hpp>

#include "hexsim/common/status.h"
#include "hexsim/gap/selftest.h"

namespace hexsim::gap {

nlohmann::json ToJson(const SelftestResult& result);
// A trial's record as hexsim.gap_selftest/1 lists it under "trials" (without its "class").
nlohmann::json ToJson(const TrialRecord& record);
// The record ToJson wrote; kNumerical naming the field when the JSON is not one.
Result<TrialRecord> TrialRecordFromJson(const nlohmann::json& j);

}  // namespace hexsim::gap
