// Regression tests on the shared real log (issue 16 item 9): ArduCopter 3.3, quad, an external
// compass (MAG) and internal ones (MAG2, MAG3), an ACRO flip at the end. The expectations are the
// physical facts an independent analysis of the file established (stacked least squares with block
// bootstrap intervals), not outputs of this code; the diagnosis is never told which log it reads.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "hexsim/common/paths.h"
#include "hexsim/gap/diagnose.h"
#include "hexsim/logs/dataflash_import.h"
#include "hexsim/common/plausibility.h"
#include "hexsim/vehicle/vehicle_io.h"
#include "hexsim/vehicle/vehicle_params.h"
#include "support/gap_fixtures.h"

namespace hexsim::gap {
namespace {

struct RealDiagnosis {
  logs::FlightLog log;
  GapReport report;
};

const RealDiagnosis& Log171() {
  static const RealDiagnosis d = [] {
    auto imp = logs::ImportDataFlashFile(std::string(HEXSIM_SOURCE_DIR) + "/data/real/ardupilot_copter_log171.bin");
    if (!imp.ok()) throw std::runtime_error(imp.status().message());
    auto path = ResolveWorldFile("vehicles", "quad_x");
    if (!path.ok()) throw std::runtime_error(path.status().message());
    auto vehicle = vehicle::LoadVehicleFile(*path);
    if (!vehicle.ok()) throw std::runtime_error(vehicle.status().message());
    DiagnoseOptions o;
    o.bootstrap_samples = 100;  // intervals from 100 block resamples keep the test fast
    auto rep = Diagnose(imp->log, *vehicle, o);
    if (!rep.ok()) throw std::runtime_error(rep.status().message());
    return RealDiagnosis{imp->log, std::move(*rep)};
  }();
  return d;
}

const CandidateResult* Primary(const ChannelResult& c) {
  for (const auto& k : c.candidates) {
    if (k.selected) return &k;
  }
  return nullptr;
}

// |k| in mG/A of a current- or throttle-driven candidate, with its interval.
bool CurrentTerms(const CandidateResult& k, double* mG_per_A, double ci[2]) {
  if (k.effect == "current_hard_iron") {
    *mG_per_A = 10 * k.magnitude;
    ci[0] = 10 * k.magnitude_ci95[0];
    ci[1] = 10 * k.magnitude_ci95[1];
    return true;
  }
  if (k.params.count("current_equivalent_uT_per_A") > 0) {
    *mG_per_A = 10 * k.params.at("current_equivalent_uT_per_A");
    ci[0] = 10 * k.ci95.at("current_equivalent_uT_per_A").lo;
    ci[1] = 10 * k.ci95.at("current_equivalent_uT_per_A").hi;
    return true;
  }
  return false;
}

TEST(GapRealLog, GivenLog171_WhenDiagnosed_ThenMag2IsCurrentDrivenAt2To9MilliGaussPerAmpWithATightInterval) {
  const GapReport& r = Log171().report;
  const ChannelResult* mag2 = gaptest::FindChannel(r, "mag2");
  ASSERT_NE(mag2, nullptr) << Summary(r);
  const CandidateResult* k = Primary(*mag2);
  ASSERT_NE(k, nullptr) << Summary(r);
  double mG = 0, ci[2] = {0, 0};
  ASSERT_TRUE(CurrentTerms(*k, &mG, ci)) << mag2->verdict << "\n" << Summary(r);
  EXPECT_EQ(mag2->verdict, k->effect);
  EXPECT_GE(mG, 2.2) << Summary(r);
  EXPECT_LE(mG, 9.0) << Summary(r);
  EXPECT_LT(ci[1] - ci[0], 10.0) << Summary(r);
  EXPECT_TRUE(k->plausible);
}

TEST(GapRealLog, GivenLog171_WhenDiagnosed_ThenTheExternalMagIsNotCurrentDrivenAndItsModelIsPlausible) {
  const GapReport& r = Log171().report;
  const ChannelResult* mag = gaptest::FindChannel(r, "mag");
  ASSERT_NE(mag, nullptr);
  for (const char* e : {"current_hard_iron", "current_soft_iron", "throttle_hard_iron", "per_motor_current_hard_iron",
                        "current_lag"}) {
    EXPECT_NE(mag->verdict, e) << Summary(r);
  }
  for (const auto& k : mag->candidates) {
    if (k.selected) {
      EXPECT_TRUE(plausibility::IsPlausible(k.effect, k.magnitude)) << k.effect << " " << k.magnitude;
    }
  }
}

TEST(GapRealLog, GivenLog171_WhenDiagnosed_ThenCompassLatencyAndCurrentStalenessAreReportedUnderTiming) {
  const GapReport& r = Log171().report;
  for (const char* name : {"mag", "mag2"}) {
    const ChannelResult* c = gaptest::FindChannel(r, name);
    ASSERT_NE(c, nullptr);
    ASSERT_TRUE(c->timing.latency.present) << name;
    const double L = c->timing.latency.value_s;
    EXPECT_GE(L, 0.020) << name;
    EXPECT_LE(L, 0.100) << name;
    const LagReport& s = c->timing.current_staleness;
    ASSERT_TRUE(s.present) << name;
    EXPECT_GE(s.value_s, 0.100) << name;
    EXPECT_LE(s.value_s, 0.400) << name;
    EXPECT_LE(s.ci95_s.lo, s.value_s);
    EXPECT_GE(s.ci95_s.hi, s.value_s);
  }
}

TEST(GapRealLog, GivenLog171_WhenWindowed_ThenTheFlipAndAfterAreExcludedAndGroundIsNeverLanding) {
  const RealDiagnosis& d = Log171();
  // The ACRO flip: the first row with |roll| or |pitch| above 90 deg.
  const auto& t = d.log.Column("t_s");
  const auto &qx = d.log.Column("q_x"), &qy = d.log.Column("q_y");
  double flip_s = NAN;
  for (size_t i = 0; i < d.log.rows() && std::isnan(flip_s); ++i) {
    const double up = 1 - 2 * (qx[i] * qx[i] + qy[i] * qy[i]);  // R_NB(2,2): cos of the tilt
    if (up < 0) flip_s = t[i];
  }
  ASSERT_TRUE(std::isfinite(flip_s));
  bool any_flight = false;
  for (const auto& w : d.report.windows) {
    if (w.kind == "flight") {
      any_flight = true;
      EXPECT_LT(w.end_s, flip_s) << "flight window reaches the flip";
    }
    if (w.end_s >= flip_s) {
      EXPECT_EQ(w.kind, "excluded") << w.start_s << ".." << w.end_s;
    }
  }
  EXPECT_TRUE(any_flight);
  // Before the first flight window the vehicle stands on the ground: never "landing".
  double first_flight = 1e9;
  for (const auto& w : d.report.windows) {
    if (w.kind == "flight") first_flight = std::min(first_flight, w.start_s);
  }
  for (const auto& p : d.report.phases) {
    if (p.t1_s < first_flight) {
      EXPECT_EQ(p.phase, "ground") << p.t0_s << ".." << p.t1_s;
    }
  }
}

// Issue 16 item 6 / issue 18: whatever a channel's verdict, the model it reports (primary and second)
// holds no fit outside its physical range: an out-of-range fit is listed as a model mismatch only.
TEST(GapRealLog, GivenLog171_WhenDiagnosed_ThenNoChannelSelectsAnImplausibleFit) {
  const GapReport& rep = Log171().report;
  ASSERT_FALSE(rep.channels.empty());
  for (const ChannelResult& c : rep.channels) {
    for (const CandidateResult& k : c.candidates) {
      if (!k.selected) continue;
      EXPECT_TRUE(k.plausible) << c.channel << ": " << k.effect << " " << k.magnitude << " " << k.magnitude_unit
                               << " is selected although outside " << k.physical_range;
    }
    EXPECT_NE(c.verdict, "") << c.channel;
  }
}

}  // namespace
}  // namespace hexsim::gap
