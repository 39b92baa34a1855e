// Timing scan and ground-vs-flight evidence of compass channels (private to gap/; see nuisance.cc).
#pragma once

#include "attribution.h"
#include "channels.h"
#include "hexsim/realdata/timing.h"
#include "verdict.h"

namespace hexsim::gap::internal {

// How stale the logged current is against the throttle, over the flight rows.
realdata::LagEstimate CurrentStaleness(const logs::FlightLog& log, const std::vector<realdata::RowKind>& kinds,
                                       const DiagnoseOptions& o);
// The exponent p of the motors' current law I_i = c·u_i^p (kShareExponent), fitted to the logged
// battery current (less the avionics', shifted by `shift_s`) against the outputs over the flight rows:
// the law's common mode, which the split of the current then uses. In [kShareExponentLo,
// kShareExponentHi] (a best fit beyond the range is read at its edge); NaN where the replay does not
// split the current (SplitsBatteryCurrent), with fewer than 100 flight rows, or where the motors draw
// no varying current above the avionics' (no power monitor: 0 A logged).
double FitShareExponent(const logs::FlightLog& log, const LogInputs& in, const vehicle::VehicleParams& v,
                        const std::vector<realdata::RowKind>& kinds, double shift_s);
// The compass latency against the attitude (and its held-out share), on the rows `base` selects.
CompassTiming ScanCompassTiming(const logs::FlightLog& log, const vehicle::VehicleParams& v, size_t c, const LogInputs& in,
                                const Vec3& B_N_uT, const CompassReplayOptions& base, const realdata::LagEstimate& stale,
                                double shift_s, const DiagnoseOptions& o);
// The lag τ of a current-driven field behind the logged current, measured as the compass latency is
// (a profile over τ, its per-block SSE and block bootstrap: realdata::ProfileLag), on a baseline-only
// replay `ch` replayed at latency_s: y = baseline + a·I_a + d·I_ref·(lp_τ(I)/I_ref)^p, I_a the
// prediction's aligned current (the wires' own field follows the current without a lag), lp_τ(I) the
// logged current through a first-order lag run over its samples, p profiled over the exponent's
// physical range (kLagExponentLo..Hi), τ over current_lag's physical range (0..2 s). Reported under
// timing whatever effect is named (as the latency is), resolved when its interval is bounded and
// clear of zero; not present without a usable current.
LagReport ScanCurrentFieldLag(const ChannelData& ch, const LogInputs& in, double latency_s, const DiagnoseOptions& o);
// The replay's plug-ins are taken as given by the fit: the latency and the current's shift (each
// estimated) and, in a log without per-motor currents, the motors' current split (kShareExponent,
// known only to lie in its range). Each reported effect (and nuisance term) is refitted with each
// plug-in at the ends of its range: the latency and the shift at the ends of their 95 % intervals,
// the split at the equal and the cubic law; half of each refit spread is added, in quadrature, to
// its 95 % half-widths (the plug-ins' own uncertainty, which the fit's intervals do not hold).
// `used`: the options the channel was replayed with.
void PropagatePlugIns(const logs::FlightLog& log, const vehicle::VehicleParams& v, size_t c, const LogInputs& in,
                     const Vec3& B_N_uT, const CompassReplayOptions& used, const CompassTiming& timing,
                     const realdata::LagEstimate& stale, const DiagnoseOptions& o, ChannelResult* res);
// How a residual offset reads against hard_iron_offset's ranges (plausibility table): a point
// outside the physical range is a model mismatch (too little rotation to separate an offset from the
// field, or the log's compass units), never a finding or the verdict; beyond the normal range where
// its judged interval is too (JudgedInterval), a finding to recalibrate; else normal.
enum class OffsetReading { kNormal, kBeyondNormal, kImplausible };
OffsetReading ReadOffset(double offset_uT, const Interval& judged);
// ΔB/ΔI between flight and ground with the flight's baseline (compassmot's principle).
GroundVsFlight CompareGroundFlight(const ChannelData& flight, const ChannelData& ground, const Nuisance& nuisance);

}  // namespace hexsim::gap::internal
