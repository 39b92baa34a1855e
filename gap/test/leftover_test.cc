// What a reported compass model leaves, described beside it (never a veto): a cross-axis coupling
// of the sensor that a misalignment half-describes.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "../src/selftest_real.h"
#include "hexsim/common/rng.h"
#include "hexsim/gap/diagnose.h"
#include "support/gap_fixtures.h"

namespace hexsim::gap {
namespace {

bool Mentions(const ChannelResult& c, const std::string& what) {
  for (const std::string& s : c.findings) {
    if (s.find(what) != std::string::npos) return true;
  }
  return false;
}

// mag2 of a real-profile trial with `injections`, its z axis also reading `coupling` times its x
// axis (a cross-axis coupling of the sensor), diagnosed against the configured vehicle.
ChannelResult DiagnoseMag2(const std::vector<Injection>& injections, uint64_t seed, double coupling, GapReport* rep_out) {
  gaptest::Flown f = gaptest::FlyInjected(injections, seed, "leftover", "selftest_flight");
  const size_t cx = static_cast<size_t>(f.log.ColumnIndex("mag2_x_uT"));
  for (size_t i = 0; i < f.log.rows(); ++i) {
    const double mx = f.log.At(i, cx);
    if (std::isfinite(mx)) f.log.MutableColumn(cx + 2)[i] += coupling * mx;
  }
  RngStream rng(seed, "leftover/degrade");
  internal::RealLogTruth truth;
  auto log = internal::DegradeToRealLog(f.log, f.trial.configured, &rng, &truth);
  EXPECT_TRUE(log.ok()) << log.status().message();
  DiagnoseOptions opt;
  opt.channels = {"mag2"};
  opt.compass_latency_s = truth.latency_s;
  auto rep = Diagnose(*log, f.trial.configured, opt);
  EXPECT_TRUE(rep.ok()) << rep.status().message();
  *rep_out = *rep;
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  EXPECT_NE(mag2, nullptr) << Summary(*rep);
  return mag2 ? *mag2 : ChannelResult();
}

// Given a compass whose z axis reads 10 % of its x axis, when diagnosed, then whatever the headline
// (in a nearly level flight the coupling reads mostly as a rotation about y: a misalignment), the
// symmetric part it leaves is reported beside it; given a true misalignment, nothing is.
TEST(GapLeftover, GivenACrossAxisCoupling_WhenDiagnosed_ThenWhatAMisalignmentLeavesIsReportedBesideIt) {
  GapReport rep;
  const ChannelResult coupled = DiagnoseMag2({}, 3201, 0.10, &rep);
  EXPECT_TRUE(coupled.gap_detected) << Summary(rep);
  EXPECT_TRUE(coupled.verdict == "unexplained" || Mentions(coupled, "cross-axis coupling")) << Summary(rep);
  EXPECT_EQ(coupled.verdict, "misalignment") << Summary(rep);  // this flight: the antisymmetric half dominates

  const ChannelResult rotated = DiagnoseMag2({{"misalignment", 5.7}}, 3201, 0.0, &rep);
  EXPECT_EQ(rotated.verdict, "misalignment") << Summary(rep);
  EXPECT_FALSE(Mentions(rotated, "cross-axis coupling")) << Summary(rep);
}

}  // namespace
}  // namespace hexsim::gap
