// Shared by the gap tests: fly a selftest trial (effects withheld from the diagnosis) and look up
// channels and candidates in a GapReport.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "../../src/selftest_real.h"
#include "hexsim/gap/diagnose.h"
#include "hexsim/gap/selftest.h"
#include "hexsim/logs/flight_log.h"

namespace hexsim::gap::gaptest {

struct Flown {
  Trial trial;
  logs::FlightLog log;
};

// Makes and flies a trial with `injections`; `stream` names the test's random stream, so each test
// file keeps its own sequence for a given seed. Failures are reported as test failures.
// `mission`: empty for the ideal profile's square; "selftest_flight" for the real profile's flight.
Flown FlyInjected(const std::vector<Injection>& injections, uint64_t seed, const std::string& stream,
                  const std::string& mission = "");

// A flown trial as a real autopilot would have logged it (selftest_real.h DegradeToRealLog), the
// degradation drawn from the stream `stream`/degrade; `truth` its latency, offset and scale.
struct FlownReal {
  Flown flown;
  logs::FlightLog log;
  internal::RealLogTruth truth;
};
FlownReal FlyAsRealLog(const std::vector<Injection>& injections, uint64_t seed, const std::string& stream,
                       const std::string& mission = "selftest_flight");

// The diagnosis options of the ideal profile: the configured vehicle is the calibrated truth, so a
// significant nuisance term (offset, field, scale) is a finding (CONTRACTS.md "Gap diagnosis").
DiagnoseOptions IdealOptions();

// `log` diagnosed on `channel` alone against `configured`, the other options their defaults; a
// diagnosis that fails is a test failure and an empty report (FindChannel then finds nothing).
GapReport DiagnoseChannel(const logs::FlightLog& log, const vehicle::VehicleParams& configured,
                          const std::string& channel);

const ChannelResult* FindChannel(const GapReport& report, const std::string& channel);
const CandidateResult* FindCandidate(const ChannelResult& channel, const std::string& effect);
// Whether `effect` is among the channel's effects.
bool InEffects(const ChannelResult& channel, const std::string& effect);
// Whether one of the channel's findings contains `text`.
bool HasFinding(const ChannelResult& channel, const std::string& text);

// selftest_flight's climbs, descents and fast and slow legs, flown holding one heading (a real log
// flown out and back along one line), written to the test's temp dir as `name`.yaml; its path.
std::string HeldHeadingMission(const std::string& name);

}  // namespace hexsim::gap::gaptest
