// Conditions real logs bring that a simulated flight does not by default: no GPS fix (no place and
// date for the Earth field model). Each test builds its case from a simulated flight.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hexsim/common/plausibility.h"
#include "hexsim/common/rng.h"
#include "hexsim/gap/diagnose.h"
#include "support/gap_fixtures.h"

namespace hexsim::gap {
namespace {

bool ChannelNotDiagnosed(const GapReport& r, const std::string& ch) {
  for (const auto& [c, why] : r.not_diagnosed) {
    if (c == ch) return true;
  }
  return false;
}

// Given a flight whose log holds no place and date (no GPS fix), when diagnosed, then its compasses
// are diagnosed against a freely fitted Earth field (as hexsim calibrate --method flight does), the
// withheld current field is found, the fitted field is the simulated one, and the verdict says so.
TEST(GapRealConditions, GivenNoPlaceAndDate_WhenDiagnosed_ThenTheEarthFieldIsFittedAndTheCurrentFieldFound) {
  gaptest::Flown f = gaptest::FlyInjected({{"current_hard_iron", 0.4}}, 3101, "real_conditions");
  auto with_place = Diagnose(f.log, f.trial.configured);
  ASSERT_TRUE(with_place.ok()) << with_place.status().message();
  const Eigen::Vector3d truth = with_place->earth_field_N_uT;
  ASSERT_GT(truth.norm(), 20.0);
  logs::FlightLog log = f.log;
  log.meta.erase("location");
  log.meta.erase("date_decimal_year");
  auto rep = Diagnose(log, f.trial.configured);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  EXPECT_FALSE(ChannelNotDiagnosed(*rep, "mag2")) << Summary(*rep);
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr) << Summary(*rep);
  EXPECT_EQ(mag2->verdict, "current_hard_iron") << Summary(*rep);
  EXPECT_NE(mag2->headline.find("Earth field fitted"), std::string::npos) << mag2->headline;
  // The field the replay used (the in-flight model's free fit): the simulated field within the
  // WMM's own prior width (flight_fit.h prior_sigma_uT, 2 µT per axis).
  EXPECT_LT((mag2->nuisance.field_prior_N_uT - truth).norm(), 2.0) << mag2->nuisance.field_prior_N_uT.transpose();
  EXPECT_EQ(mag2->nuisance.field_source.rfind("fitted", 0), 0u) << mag2->nuisance.field_source;
}

// Keeps one compass sample every `period_s` (PX4 logs its compass at 1-2 Hz): the other rows'
// readings and time stamps are removed, as a log that never held them.
void ThinCompass(logs::FlightLog* log, const std::string& pre, double period_s) {
  const auto& t = log->Column("t_s");
  std::vector<size_t> cols;
  for (const char* s : {"_x_uT", "_y_uT", "_z_uT", "_t_s"}) {
    if (log->Has(pre + s)) cols.push_back(static_cast<size_t>(log->ColumnIndex(pre + s)));
  }
  double next = -1e300;
  for (size_t i = 0; i < log->rows(); ++i) {
    if (t[i] >= next && std::isfinite(log->Column(cols[0])[i])) {
      next = t[i] + period_s;
      continue;
    }
    for (size_t c : cols) log->MutableColumn(c)[i] = std::nan("");
  }
}

// Given a compass logged at 1.6 Hz (about a hundred samples in flight) with a current field of
// 4 mG/A, when diagnosed, then the current field is found. The cluster-robust tests' blocks follow
// time and the in-flight model's 5 samples per block: 30-sample blocks left such a compass 4 blocks,
// and a 3-parameter effect cannot be shown on 4 blocks (F(3, 1)).
TEST(GapRealConditions, GivenACompassLoggedAtPx4sRate_WhenDiagnosed_ThenItsCurrentFieldIsFound) {
  gaptest::Flown f = gaptest::FlyInjected({{"current_hard_iron", 0.4}}, 3107, "real_conditions");
  ThinCompass(&f.log, "mag2", 0.625);
  auto rep = Diagnose(f.log, f.trial.configured);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr) << Summary(*rep);
  EXPECT_LT(mag2->samples, 200) << "the thinning kept too many samples";
  EXPECT_EQ(mag2->verdict, "current_hard_iron") << Summary(*rep);
}

// Given clean flights (nothing withheld) whose compass is logged at 1.6 Hz, when diagnosed, then
// no compass effect is found: the shorter blocks do not make the cluster-robust tests anti-conservative.
TEST(GapRealConditions, GivenCleanFlightsWithACompassAtPx4sRate_WhenDiagnosed_ThenNoCompassEffectIsFound) {
  for (uint64_t seed : {3109u, 3111u, 3113u, 3115u, 3117u, 3119u}) {
    gaptest::Flown f = gaptest::FlyInjected({}, seed, "real_conditions");
    ThinCompass(&f.log, "mag2", 0.625);
    ThinCompass(&f.log, "mag", 0.625);
    auto rep = Diagnose(f.log, f.trial.configured);
    ASSERT_TRUE(rep.ok()) << rep.status().message();
    for (const char* ch : {"mag", "mag2"}) {
      const ChannelResult* c = gaptest::FindChannel(*rep, ch);
      ASSERT_NE(c, nullptr) << Summary(*rep);
      if (!c->effects.empty()) ADD_FAILURE() << "seed " << seed << " " << ch << ": " << c->headline;
    }
  }
}

}  // namespace
}  // namespace hexsim::gap
