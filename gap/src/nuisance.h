// Timing scan and ground-vs-flight evidence of compass channels (private to gap/; see nuisance.cc).
#pragma once

#include <nlohmann/json.hpp>

#include "attribution.h"
#include "channels.h"
#include "hexsim/realdata/timing.h"
#include "verdict.h"

namespace hexsim::gap::internal {

// How stale the logged current is against the throttle, over the flight rows.
realdata::LagEstimate CurrentStaleness(const logs::FlightLog& log, const std::vector<realdata::RowKind>& kinds,
                                       const DiagnoseOptions& o);
// The compass latency against the attitude (and its held-out share), on the rows `base` selects.
CompassTiming ScanCompassTiming(const logs::FlightLog& log, const vehicle::VehicleParams& v, size_t c, const LogInputs& in,
                                const Vec3& B_N_uT, const CompassReplayOptions& base, const realdata::LagEstimate& stale,
                                double shift_s, const DiagnoseOptions& o);
// The latency and the current's shift are estimated, then taken as given: each reported effect (and
// nuisance term) is refitted with the latency at the ends of its 95 % interval and with the shift
// at the ends of the staleness's; half of each refit spread is added, in quadrature, to its 95 %
// half-widths (the plug-ins' own uncertainty, which the fit's intervals do not hold). `used`: the
// options the channel was replayed with.
void PropagateTiming(const logs::FlightLog& log, const vehicle::VehicleParams& v, size_t c, const LogInputs& in,
                     const Vec3& B_N_uT, const CompassReplayOptions& used, const CompassTiming& timing,
                     const realdata::LagEstimate& stale, const DiagnoseOptions& o, ChannelResult* res);
// ΔB/ΔI between flight and ground with the flight's baseline (compassmot's principle).
nlohmann::json GroundVsFlight(const ChannelData& flight, const ChannelData& ground, const nlohmann::json& nuisance);

}  // namespace hexsim::gap::internal
