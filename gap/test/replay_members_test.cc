// Which of current_lag's free members a replay builds: every (τ, exponent) pair of the diagnosis, or
// the lag profile of one exponent (the plug-in refits of PropagatePlugIns, which profile the lag again
// within the reported member's form only).
#include <cmath>
#include <iterator>
#include <set>

#include <gtest/gtest.h>

#include "../src/channels.h"
#include "../src/replay_util.h"

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

}  // namespace
}  // namespace hexsim::gap
