// Conditions real logs bring that a simulated flight does not by default: no GPS fix (no place and
// date for the Earth field model). Each test builds its case from a simulated flight.
#include <cmath>
#include <string>

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

}  // namespace
}  // namespace hexsim::gap
