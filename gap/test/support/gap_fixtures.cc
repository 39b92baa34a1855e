#include "support/gap_fixtures.h"

#include <utility>

#include <gtest/gtest.h>

#include "hexsim/common/rng.h"

namespace hexsim::gap::gaptest {

Flown FlyInjected(const std::vector<Injection>& injections, uint64_t seed, const std::string& stream,
                  const std::string& mission) {
  SelftestOptions options;
  options.mission = mission;
  RngStream rng(seed, stream);
  auto trial = MakeTrial(options, seed, injections, &rng);
  EXPECT_TRUE(trial.ok()) << trial.status().message();
  auto log = FlyTrial(&*trial, &rng);
  EXPECT_TRUE(log.ok()) << log.status().message();
  return {std::move(*trial), std::move(*log)};
}

DiagnoseOptions IdealOptions() {
  DiagnoseOptions o;
  o.nuisance_ranges = "exact";
  return o;
}

const ChannelResult* FindChannel(const GapReport& report, const std::string& channel) {
  for (const auto& c : report.channels) {
    if (c.channel == channel) return &c;
  }
  return nullptr;
}

const CandidateResult* FindCandidate(const ChannelResult& channel, const std::string& effect) {
  for (const auto& k : channel.candidates) {
    if (k.effect == effect) return &k;
  }
  return nullptr;
}

}  // namespace hexsim::gap::gaptest
