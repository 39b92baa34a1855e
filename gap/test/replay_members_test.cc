// Which of current_lag's free members a replay builds: every (τ, exponent) pair of the diagnosis, or
// the lag profile of one exponent (the plug-in refits of PropagatePlugIns, which profile the lag again
// within the reported member's form only).
#include <algorithm>
#include <cmath>
#include <iterator>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "../src/channels.h"
#include "../src/replay_util.h"
#include "hexsim/realdata/windows.h"
#include "support/gap_fixtures.h"

namespace hexsim::gap {
namespace {

// A 60 s channel at 10 Hz whose current steps between 8 and 16 A every 5 s.
internal::ChannelData SteppedCurrent() {
  internal::ChannelData ch;
  for (int k = 0; k < 600; ++k) {
    ch.t.push_back(0.1 * k);
    ch.current_A.push_back((k / 50) % 2 == 0 ? 8.0 : 16.0);
  }
  return ch;
}

TEST(GapReplayMembers, GivenNoExponent_WhenTheFreeLagMembersAreBuilt_ThenEveryLagAndExponentPairIsAMember) {
  internal::ChannelData ch = SteppedCurrent();
  internal::AddLaggedCurrentField(&ch);
  const size_t taus = 1 + std::size(internal::kLagGrid_s), exponents = std::size(internal::kLagExponents);
  EXPECT_EQ(ch.candidates.size(), taus * exponents);
}

TEST(GapReplayMembers, GivenTheReportedExponent_WhenTheFreeLagMembersAreBuilt_ThenOnlyItsLagProfileIsBuilt) {
  internal::ChannelData ch = SteppedCurrent();
  internal::AddLaggedCurrentField(&ch, 1.5);
  std::set<double> taus;
  for (const internal::Candidate& c : ch.candidates) {
    EXPECT_EQ(c.grid2_value, 1.5);
    EXPECT_EQ(c.X.size(), ch.t.size());
    taus.insert(c.grid_value);
  }
  // The whole lag profile at that exponent: τ = 0 and every grid lag.
  EXPECT_EQ(taus.size(), 1 + std::size(internal::kLagGrid_s));
  EXPECT_EQ(ch.candidates.size(), taus.size());
}


// The current iron families' members of a replay: one per member shift, or only the shifts the
// plug-in refits ask for (only_member_shifts_s), each the same member as in the full replay on the
// same samples.
TEST(GapReplayMembers, GivenOnlyTheReportedShift_WhenTheCurrentIronMembersAreBuilt_ThenOnlyItsMembersAreBuiltAsInTheFullReplay) {
  const gaptest::Flown f = gaptest::FlyInjected({{"current_hard_iron", 0.5}}, 3, "gap_replay_members");
  const realdata::FlightWindows fw = realdata::FindFlightWindows(f.log);
  const internal::ReplayResult rr = internal::Replay(f.log, f.trial.configured, DiagnoseOptions{}, fw.row_kind);
  ASSERT_FALSE(rr.compasses.empty());
  internal::CompassReplayOptions ro;
  ro.row_kind = &fw.row_kind;
  ro.member_shifts_s = {0.05, 0.1, 0.15, 0.2};
  ro.only_families = {Effect::kCurrentHardIron, Effect::kCurrentSoftIron};
  const size_t c = rr.compasses.front();
  const internal::ChannelData all = internal::ReplayCompass(f.log, f.trial.configured, c, rr.inputs, rr.earth_field_N_uT, ro);
  ro.only_member_shifts_s = {0.15};
  const internal::ChannelData only = internal::ReplayCompass(f.log, f.trial.configured, c, rr.inputs, rr.earth_field_N_uT, ro);
  ASSERT_GT(only.t.size(), 100u);
  EXPECT_EQ(only.t, all.t);  // the samples of every member shift, as in the full replay
  std::vector<std::string> effects;
  for (const internal::Candidate& k : only.candidates) {
    if (k.grid_name != "current_aligned") continue;
    EXPECT_EQ(k.grid_value, 0.15) << k.effect;
    effects.push_back(k.effect);
    const auto same = std::find_if(all.candidates.begin(), all.candidates.end(), [&](const internal::Candidate& a) {
      return a.effect == k.effect && a.grid_value == k.grid_value;
    });
    ASSERT_NE(same, all.candidates.end()) << k.effect;
    ASSERT_EQ(same->X.size(), k.X.size());
    for (size_t i = 0; i < k.X.size(); ++i) ASSERT_EQ(same->X[i], k.X[i]) << k.effect << " sample " << i;
  }
  std::sort(effects.begin(), effects.end());
  EXPECT_EQ(effects, (std::vector<std::string>{"current_hard_iron", "current_soft_iron"}));
  EXPECT_EQ(all.candidates.size(), 2u * 5);  // the logged current and four shifts, two families
}

}  // namespace
}  // namespace hexsim::gap
