// Which vehicle compass a log compass is compared with (compass_map.h), the compass channels'
// derived minimum sample count (CompassMinSamples), and the field scale's own name.
#include <algorithm>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "../src/channels.h"
#include "../src/compass_map.h"
#include "../src/selftest_real.h"
#include "hexsim/common/paths.h"
#include "hexsim/common/rng.h"
#include "hexsim/gap/diagnose.h"
#include "hexsim/gap/json.h"
#include "hexsim/logs/dataflash_import.h"
#include "hexsim/vehicle/vehicle_io.h"
#include "support/gap_fixtures.h"

namespace hexsim::gap {
namespace {

vehicle::VehicleParams MappingQuadX() {
  auto path = ResolveWorldFile("vehicles", "quad_x");
  EXPECT_TRUE(path.ok());
  auto v = vehicle::LoadVehicleFile(*path);
  EXPECT_TRUE(v.ok()) << v.status().message();
  return *v;
}

// Two compass columns with data and the meta's external flags as given (null: not stated).
logs::FlightLog MappingTwoCompassLog(const nlohmann::json& mag_external, const nlohmann::json& mag2_external) {
  logs::FlightLog log;
  for (const char* c : {"t_s", "mag_x_uT", "mag2_x_uT"}) log.AddColumn(c);
  log.AppendRow();
  log.Set("t_s", 0.0);
  log.Set("mag_x_uT", 20.0);
  log.Set("mag2_x_uT", 21.0);
  log.meta["compasses"] = {{{"column", "mag"}, {"external", mag_external}},
                           {{"column", "mag2"}, {"external", mag2_external}}};
  return log;
}

// quad_x: compass 1 external (on the mast), 2 and 3 internal. A PX4 log: mag internal, mag2 external.
TEST(CompassMapping, GivenALogWhoseExternalCompassIsItsSecond_WhenMapped_ThenEachTakesTheVehiclesCompassOfItsKind) {
  const vehicle::VehicleParams v = MappingQuadX();
  ASSERT_EQ(v.compasses.size(), 3u);
  ASSERT_TRUE(v.compasses[0].external);
  const CompassMapping m = internal::MapCompasses(MappingTwoCompassLog(false, true), v);
  EXPECT_EQ(m.method, "external_flag");
  ASSERT_EQ(m.pairs.size(), 2u);
  EXPECT_EQ(m.pairs[0].channel, "mag");
  EXPECT_EQ(m.pairs[0].vehicle_compass, 2);
  EXPECT_FALSE(m.pairs[0].external);
  EXPECT_EQ(m.pairs[1].vehicle_compass, 1);
  EXPECT_TRUE(m.pairs[1].external);
  // The reordered vehicle: compass c is log compass c's; the third keeps the free place.
  const vehicle::VehicleParams r = internal::WithCompassesInLogOrder(v, m);
  EXPECT_TRUE(r.compasses[0].position_B_m.isApprox(v.compasses[1].position_B_m));
  EXPECT_TRUE(r.compasses[1].position_B_m.isApprox(v.compasses[0].position_B_m));
  EXPECT_TRUE(r.compasses[2].position_B_m.isApprox(v.compasses[2].position_B_m));
  // An ArduPilot-like log whose first compass is the external one maps by index, as before.
  const CompassMapping same = internal::MapCompasses(MappingTwoCompassLog(true, false), v);
  EXPECT_EQ(same.method, "external_flag");
  EXPECT_EQ(same.pairs[0].vehicle_compass, 1);
  EXPECT_EQ(same.pairs[1].vehicle_compass, 2);
}

TEST(CompassMapping, GivenAFlagMissingOrAVehicleThatMarksNone_WhenMapped_ThenByIndexWithTheReason) {
  vehicle::VehicleParams v = MappingQuadX();
  CompassMapping m = internal::MapCompasses(MappingTwoCompassLog(false, nullptr), v);
  EXPECT_EQ(m.method, "index");
  EXPECT_NE(m.why.find("mag2"), std::string::npos) << m.why;
  EXPECT_EQ(m.pairs[0].vehicle_compass, 1);
  for (auto& c : v.compasses) c.external = false;
  m = internal::MapCompasses(MappingTwoCompassLog(false, true), v);
  EXPECT_EQ(m.method, "index");
  EXPECT_NE(m.why.find("marks no compass external"), std::string::npos) << m.why;
  // An internal log compass and a vehicle with none internal: by index, saying so.
  vehicle::VehicleParams ext_only = MappingQuadX();
  for (auto& c : ext_only.compasses) c.external = true;
  m = internal::MapCompasses(MappingTwoCompassLog(false, true), ext_only);
  EXPECT_EQ(m.method, "index");
  EXPECT_NE(m.why.find("no internal compass for mag"), std::string::npos) << m.why;
}

// Two external compasses in the log, one in the vehicle (quad_x): the second shares the file's
// external compass, said so, and is never compared with an internal one on the board (whose wiring
// field is another: a public ArduCopter 4.5.7 log's mast compass read 3.3 mG/A against quad_x's
// internal compass's modelled field, its absolute term 1.8).
TEST(CompassMapping, GivenMoreExternalCompassesThanTheVehicleHas_WhenMapped_ThenTheyShareItsExternalOne) {
  const vehicle::VehicleParams v = MappingQuadX();
  const CompassMapping m = internal::MapCompasses(MappingTwoCompassLog(true, true), v);
  EXPECT_EQ(m.method, "external_flag");
  ASSERT_EQ(m.pairs.size(), 2u);
  EXPECT_EQ(m.pairs[0].vehicle_compass, 1);
  EXPECT_EQ(m.pairs[1].vehicle_compass, 1);
  EXPECT_TRUE(m.pairs[1].external);
  EXPECT_NE(m.why.find("mag2 shares compass 1"), std::string::npos) << m.why;
  const vehicle::VehicleParams r = internal::WithCompassesInLogOrder(v, m);
  EXPECT_TRUE(r.compasses[1].external);
  EXPECT_TRUE(r.compasses[1].position_B_m.isApprox(v.compasses[0].position_B_m));
}

// log171 with MAG and MAG2 swapped (a log whose first compass is the internal one, as PX4 logs
// it): its `mag` holds MAG2's internal readings, so its absolute terms must subtract quad_x's
// internal compass's modelled wiring field (compass 2), not the mast compass's near-zero one.
TEST(CompassMapping, GivenLog171WithItsCompassesSwapped_WhenDiagnosed_ThenMagIsComparedWithTheInternalCompass) {
  auto imp = logs::ImportDataFlashFile(std::string(HEXSIM_SOURCE_DIR) + "/data/real/ardupilot_copter_log171.bin");
  ASSERT_TRUE(imp.ok()) << imp.status().message();
  const logs::FlightLog& in = imp->log;
  logs::FlightLog log;
  auto swapped = [](const std::string& name) {
    if (name.rfind("mag_", 0) == 0) return "mag2_" + name.substr(4);
    if (name.rfind("mag2_", 0) == 0) return "mag_" + name.substr(5);
    return name;
  };
  for (const auto& name : in.columns()) log.AddColumn(swapped(name));
  for (size_t i = 0; i < in.rows(); ++i) {
    log.AppendRow();
    for (const auto& name : in.columns()) log.Set(swapped(name), in.Column(name)[i]);
  }
  log.meta = in.meta;
  for (auto& c : log.meta["compasses"]) {
    const std::string col = c["column"].get<std::string>();
    c["column"] = col == "mag" ? "mag2" : col == "mag2" ? "mag" : col;
  }
  const vehicle::VehicleParams v = MappingQuadX();
  DiagnoseOptions o;
  o.bootstrap_samples = 50;
  o.from_s = 120.0;
  o.to_s = 155.0;
  o.channels = {"mag"};
  auto rep = Diagnose(log, v, o);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  EXPECT_EQ(rep->compass_mapping.method, "external_flag") << rep->compass_mapping.why;
  const ChannelResult* mag = gaptest::FindChannel(*rep, "mag");
  ASSERT_NE(mag, nullptr) << Summary(*rep);
  EXPECT_EQ(mag->vehicle_compass, 2);
  ASSERT_TRUE(mag->absolute_terms.has_value());
  // quad_x models 3.8 mG/A at its internal compass and 0.2 mG/A on the mast (CONTRACTS, quad_x.yaml).
  EXPECT_GT(kMilliGaussPerMicroTesla * mag->absolute_terms->modelled_uT_per_A.norm(), 1.0);
  EXPECT_NE(Summary(*rep).find("mag → compass 2 (internal)"), std::string::npos) << Summary(*rep);
  EXPECT_EQ(ToJson(*rep)["compass_mapping"]["method"], "external_flag");
}

// A 25 s piece of a flight logged at real rates (10 Hz compass: ~250 samples) whose in-flight model
// cannot fit (its log holds no flight): gap's own analysis needs 2·10·unknowns/3 samples, not 400.
TEST(CompassMinimum, GivenAShortLogAtRealRates_WhenTheInFlightModelCannotFit_ThenGapStillDiagnosesTheCompass) {
  gaptest::Flown f = gaptest::FlyInjected({{"current_hard_iron", 0.5}}, 2901, "compass_minimum", "selftest_flight");
  RngStream rng(2901, "compass_minimum");
  internal::RealLogTruth lt;
  auto log = internal::DegradeToRealLog(f.log, f.trial.configured, &rng, &lt);
  ASSERT_TRUE(log.ok()) << log.status().message();
  logs::FlightLog ground;  // the log's first rows only: no flight for the in-flight model
  for (const auto& name : log->columns()) ground.AddColumn(name);
  for (size_t i = 0; i < 20; ++i) {
    ground.AppendRow();
    for (const auto& name : log->columns()) ground.Set(name, log->Column(name)[i]);
  }
  ground.meta = log->meta;
  DiagnoseOptions o;
  o.bootstrap_samples = 50;
  o.compass_latency_s = lt.latency_s;
  const double t0 = log->Column("t_s").front();
  o.from_s = t0 + 10.0;
  o.to_s = t0 + 35.0;
  o.channels = {"mag2"};
  o.compass_model_log = &ground;
  auto rep = Diagnose(*log, f.trial.configured, o);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  for (const auto& [ch, why] : rep->not_diagnosed) EXPECT_NE(ch, "mag2") << why;
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr) << Summary(*rep);
  EXPECT_FALSE(mag2->absolute_terms.has_value());
  EXPECT_LT(mag2->samples, o.min_samples);
  EXPECT_GT(mag2->samples, 150);
  // The field scale is a nuisance term of its own name; no name is both a nuisance term and a fitted family.
  std::set<std::string> nuisance, fitted;
  for (const CandidateResult& k : mag2->candidates) (k.nuisance_term ? nuisance : fitted).insert(k.effect);
  EXPECT_EQ(nuisance.count("field_scale"), 1u);
  for (const std::string& e : nuisance) EXPECT_EQ(fitted.count(e), 0u) << e;
}

}  // namespace
}  // namespace hexsim::gap
