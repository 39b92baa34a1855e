#include "support/gap_fixtures.h"

#include <fstream>
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

FlownReal FlyAsRealLog(const std::vector<Injection>& injections, uint64_t seed, const std::string& stream,
                       const std::string& mission) {
  FlownReal r{FlyInjected(injections, seed, stream, mission), {}, {}};
  RngStream rng(seed, stream + "/degrade");
  auto log = internal::DegradeToRealLog(r.flown.log, r.flown.trial.configured, &rng, &r.truth);
  EXPECT_TRUE(log.ok()) << log.status().message();
  if (log.ok()) r.log = std::move(*log);
  return r;
}

DiagnoseOptions IdealOptions() {
  DiagnoseOptions o;
  o.nuisance_ranges = "exact";
  return o;
}

GapReport DiagnoseChannel(const logs::FlightLog& log, const vehicle::VehicleParams& configured,
                          const std::string& channel) {
  DiagnoseOptions o;
  o.channels = {channel};
  auto rep = Diagnose(log, configured, o);
  if (!rep.ok()) {
    ADD_FAILURE() << rep.status().message();
    return {};
  }
  return std::move(*rep);
}

const ChannelResult* FindChannel(const GapReport& report, const std::string& channel) {
  for (const auto& c : report.channels) {
    if (c.channel == channel) return &c;
  }
  return nullptr;
}

bool InEffects(const ChannelResult& channel, const std::string& effect) {
  for (const EffectShare& e : channel.effects) {
    if (e.effect == effect) return true;
  }
  return false;
}

bool HasFinding(const ChannelResult& channel, const std::string& text) {
  for (const std::string& s : channel.findings) {
    if (s.find(text) != std::string::npos) return true;
  }
  return false;
}

std::string HeldHeadingMission(const std::string& name) {
  std::string path = ::testing::TempDir() + name + ".yaml";
  std::ofstream(path) << "name: " << name << "\nspeed_mps: 8\nacceptance_radius_m: 1.5\nyaw_mode: hold\n"
                      << "wind: {mean_N_mps: [0, 5, 0], gust_std_mps: 0.8}\nitems:\n"
                         "  - {type: takeoff, alt_m: 10}\n"
                         "  - {type: waypoint, p_N_m: [60, 0, -40], speed_mps: 8}\n"
                         "  - {type: waypoint, p_N_m: [60, 80, -40], speed_mps: 13}\n"
                         "  - {type: waypoint, p_N_m: [0, 80, -12], speed_mps: 8}\n"
                         "  - {type: waypoint, p_N_m: [-60, 80, -12], speed_mps: 13}\n"
                         "  - {type: waypoint, p_N_m: [-60, 0, -35], speed_mps: 8}\n"
                         "  - {type: waypoint, p_N_m: [0, 0, -10], speed_mps: 4}\n"
                         "  - {type: land}\n";
  return path;
}

const CandidateResult* FindCandidate(const ChannelResult& channel, const std::string& effect) {
  for (const auto& k : channel.candidates) {
    if (k.effect == effect) return &k;
  }
  return nullptr;
}

}  // namespace hexsim::gap::gaptest
