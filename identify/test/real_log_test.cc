// Identification on the shared real log (ArduCopter 3.3 quad, log171; issue 18's checks): the vehicle
// identified on the even time blocks of the flight windows is judged on the odd (held-out) blocks by
// gap's dynamics channel, against the generic quad_x on the same rows. Neither side is told which log
// it reads; the expectations are the issue's, not outputs of this code.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <utility>
#include <vector>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "hexsim/common/paths.h"
#include "hexsim/common/plausibility.h"
#include "hexsim/gap/diagnose.h"
#include "hexsim/identify/identify.h"
#include "hexsim/logs/dataflash_import.h"
#include "hexsim/vehicle/vehicle_io.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::identify {
namespace {

struct RealCase {
  logs::FlightLog log;
  IdentifyResult identified;
  gap::GapReport vs_base, vs_identified;  // both on the held-out blocks
};

const RealCase& Log171() {
  static const RealCase c = [] {
    auto imp = logs::ImportDataFlashFile(std::string(HEXSIM_SOURCE_DIR) + "/data/real/ardupilot_copter_log171.bin");
    if (!imp.ok()) throw std::runtime_error(imp.status().message());
    auto path = ResolveWorldFile("vehicles", "quad_x");
    if (!path.ok()) throw std::runtime_error(path.status().message());
    auto base = vehicle::LoadVehicleFile(*path);
    if (!base.ok()) throw std::runtime_error(base.status().message());
    IdentifyOptions io;  // as `gap diagnose` without --sim: fit on the even blocks
    io.bootstrap_samples = 50;
    for (int b = 0; b < io.blocks; b += 2) io.fit_blocks.push_back(b);
    auto r = Identify(imp->log, *base, io);
    if (!r.ok()) throw std::runtime_error(r.status().message());
    const logs::FlightLog held = HeldOutLog(imp->log, *r);
    gap::DiagnoseOptions o;
    o.bootstrap_samples = 50;  // the residuals do not depend on it; the intervals are not checked here
    o.timing_scan = false;
    auto q = gap::Diagnose(held, *base, o);
    auto i = gap::Diagnose(held, ApplyIdentified(*base, *r), o);
    if (!q.ok() || !i.ok()) throw std::runtime_error("diagnosis failed");
    return RealCase{imp->log, *r, std::move(*q), std::move(*i)};
  }();
  return c;
}

const gap::ChannelResult* Channel(const gap::GapReport& r, const std::string& name) {
  for (const auto& c : r.channels) {
    if (c.channel == name) return &c;
  }
  return nullptr;
}

bool InFlightWindow(const gap::GapReport& r, double t) {
  for (const auto& w : r.windows) {
    if (w.kind == "flight" && t >= w.start_s && t <= w.end_s) return true;
  }
  return false;
}

TEST(IdentifyRealLog, GivenLog171_WhenIdentifiedOnEvenBlocks_ThenTheHeldOutDynamicsResidualFallsByHalfAgainstQuadX) {
  const RealCase& c = Log171();
  const gap::ChannelResult* base = Channel(c.vs_base, "dynamics");
  const gap::ChannelResult* ident = Channel(c.vs_identified, "dynamics");
  ASSERT_NE(base, nullptr) << gap::Summary(c.vs_base);
  ASSERT_NE(ident, nullptr) << gap::Summary(c.vs_identified);
  // The same held-out samples on both sides, every one inside a flight window.
  ASSERT_EQ(base->samples, ident->samples);
  ASSERT_GE(ident->samples, 400);
  for (double t : ident->t_s) ASSERT_TRUE(InFlightWindow(c.vs_identified, t)) << t;
  std::printf("log171 held-out dynamics residual in flight windows (%d samples): quad_x %.3f m/s^2, identified %.3f m/s^2 "
              "(%.0f %% lower)\n",
              ident->samples, base->rms_before, ident->rms_before, 100.0 * (1.0 - ident->rms_before / base->rms_before));
  EXPECT_LE(ident->rms_before, 0.5 * base->rms_before)
      << "held-out dynamics residual: quad_x " << base->rms_before << " m/s^2, identified " << ident->rms_before;
}

// Issue 18: no dynamics verdict on a real log carries an out-of-range magnitude, against the generic
// vehicle or the identified one; the inertial channels likewise report plausible fits only.
TEST(IdentifyRealLog, GivenLog171_WhenDiagnosedAgainstEitherVehicle_ThenNoSelectedFitIsOutOfRange) {
  for (const gap::GapReport* r : {&Log171().vs_base, &Log171().vs_identified}) {
    for (const char* name : {"dynamics", "accel", "gyro"}) {
      const gap::ChannelResult* ch = Channel(*r, name);
      ASSERT_NE(ch, nullptr) << name;
      for (const auto& k : ch->candidates) {
        if (!k.selected && k.effect != ch->verdict) continue;
        EXPECT_TRUE(k.plausible) << name << ": " << k.effect << " " << k.magnitude << " outside " << k.physical_range;
        EXPECT_TRUE(plausibility::IsPlausible(k.effect, k.magnitude)) << name << ": " << k.effect << " " << k.magnitude;
      }
    }
  }
}

// Every parameter identify applies is inside the shared table's range, with its interval.
TEST(IdentifyRealLog, GivenLog171_WhenIdentified_ThenEveryAppliedParameterAndItsIntervalAreInsideItsPhysicalRange) {
  const IdentifyResult& r = Log171().identified;
  int applied = 0;
  for (const auto& [name, p] : r.params) {
    if (!p.applied) continue;
    ++applied;
    EXPECT_TRUE(plausibility::IsPlausible(name, p.ci95[0]) && plausibility::IsPlausible(name, p.ci95[1]))
        << name << " [" << p.ci95[0] << ", " << p.ci95[1] << "] outside " << plausibility::RangeText(name);
  }
  EXPECT_GE(applied, 3);
}

// The log's own steady hover (level, slow, measured vertical specific force within 0.5 m/s^2 of g),
// each sample's motor output referred to V_ref (x = u·V/V_ref, the identification's thrust variable):
// its median lies inside the identified hover output's interval.
TEST(IdentifyRealLog, GivenLog171_WhenIdentified_ThenTheHoverOutputIntervalHoldsTheLogsSteadyHoverOutputs) {
  const IdentifyResult& r = Log171().identified;
  ASSERT_GE(r.hover_output.size(), 100u);
  ASSERT_GT(r.v_ref_V, 0.0);
  std::vector<double> x;
  for (size_t k = 0; k < r.hover_output.size(); ++k) x.push_back(r.hover_output[k] * r.hover_voltage_V[k] / r.v_ref_V);
  std::nth_element(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(x.size() / 2), x.end());
  const double median = x[x.size() / 2];
  const Param& h = r.params.at("hover_output");
  std::printf("log171 steady hover output %.4f (%zu samples), identified %.4f [%.4f, %.4f]\n", median, x.size(), h.value,
              h.ci95[0], h.ci95[1]);
  EXPECT_GE(median, h.ci95[0]);
  EXPECT_LE(median, h.ci95[1]);
}

// The battery resistance against the plain slope of voltage on current: least squares within 5-s
// segments of the flight windows, each with its own intercept (the open-circuit voltage barely moves
// in 5 s; the current swings with every manoeuvre). That slope lies inside the identified interval.
TEST(IdentifyRealLog, GivenLog171_WhenIdentified_ThenBatteryResistanceHoldsTheVoltageCurrentSlope) {
  const RealCase& c = Log171();
  const logs::FlightLog* batt = c.log.Stream("batt");
  ASSERT_NE(batt, nullptr);
  const auto& t = batt->Column("t_s");
  const auto& I = batt->Column("current_A");
  const auto& V = batt->Column("voltage_V");
  constexpr double kSegment_s = 5.0;
  std::map<long, std::vector<std::pair<double, double>>> seg;
  for (size_t k = 0; k < t.size(); ++k) {
    bool in = false;
    for (const auto& w : c.identified.windows) in = in || (w.kind == "flight" && t[k] >= w.start_s && t[k] <= w.end_s);
    if (in && std::isfinite(I[k]) && std::isfinite(V[k])) seg[std::lround(std::floor(t[k] / kSegment_s))].emplace_back(I[k], V[k]);
  }
  double sxy = 0, sxx = 0;
  for (const auto& [id, pts] : seg) {
    if (pts.size() < 3) continue;
    double mi = 0, mv = 0;
    for (const auto& [i, v] : pts) {
      mi += i / static_cast<double>(pts.size());
      mv += v / static_cast<double>(pts.size());
    }
    for (const auto& [i, v] : pts) {
      sxy += (i - mi) * (v - mv);
      sxx += (i - mi) * (i - mi);
    }
  }
  ASSERT_GT(sxx, 0.0);
  const double slope_ohm = -sxy / sxx;
  const Param& R = c.identified.params.at("battery_resistance_ohm");
  std::printf("log171 dV/dI within %.0f-s segments %.4f ohm, identified %.4f [%.4f, %.4f]\n", kSegment_s, slope_ohm,
              R.value, R.ci95[0], R.ci95[1]);
  EXPECT_EQ(R.source, "fitted");
  EXPECT_GE(slope_ohm, R.ci95[0]);
  EXPECT_LE(slope_ohm, R.ci95[1]);
}

}  // namespace
}  // namespace hexsim::identify
