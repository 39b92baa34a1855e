// A compass channel's absolute terms from the in-flight model (compass_terms.h) on the shared real
// log: short logs are diagnosed wherever the model fits them, and gap's calib.parm handles the
// log's own COMPASS_MOTCT / COMPASS_MOT* as it says.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "../src/compass_terms_fit.h"
#include "hexsim/common/paths.h"
#include "hexsim/gap/diagnose.h"
#include "hexsim/logs/dataflash_import.h"
#include "hexsim/magnetics/flight_fit.h"
#include "hexsim/realdata/windows.h"
#include "hexsim/vehicle/vehicle_io.h"

namespace hexsim::gap {
namespace {

struct Fixture {
  logs::FlightLog log;
  vehicle::VehicleParams vehicle;
};

const Fixture& Log171() {
  static const Fixture f = [] {
    auto imp = logs::ImportDataFlashFile(std::string(HEXSIM_SOURCE_DIR) + "/data/real/ardupilot_copter_log171.bin");
    if (!imp.ok()) throw std::runtime_error(imp.status().message());
    auto path = ResolveWorldFile("vehicles", "quad_x");
    if (!path.ok()) throw std::runtime_error(path.status().message());
    auto v = vehicle::LoadVehicleFile(*path);
    if (!v.ok()) throw std::runtime_error(v.status().message());
    return Fixture{imp->log, *v};
  }();
  return f;
}

// A 35 s piece of the flight holds fewer compass samples than the channels' min_samples (400 at
// 10 Hz): the in-flight model still fits it (12 blocks of ~3 s), so the compasses are diagnosed.
TEST(CompassTerms, GivenAShortPieceOfFlight_WhenDiagnosed_ThenTheCompassesAreDiagnosedWithTheirAbsoluteTerms) {
  const Fixture& f = Log171();
  DiagnoseOptions o;
  o.bootstrap_samples = 50;
  o.from_s = 120.0;
  o.to_s = 155.0;
  o.channels = {"mag2"};
  auto rep = Diagnose(f.log, f.vehicle, o);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  for (const auto& [ch, why] : rep->not_diagnosed) EXPECT_NE(ch, "mag2") << why;
  const ChannelResult* mag2 = nullptr;
  for (const auto& c : rep->channels) {
    if (c.channel == "mag2") mag2 = &c;
  }
  ASSERT_NE(mag2, nullptr);
  ASSERT_TRUE(mag2->absolute_terms.has_value());
  EXPECT_LT(mag2->absolute_terms->samples, o.min_samples);
  EXPECT_GE(mag2->absolute_terms->blocks, 6);
}

// A log with no flight (never armed: a bench or calibration-dance log) leaves the compass channel
// no flight sample; the in-flight model still fits the ground rotations (as calibrate does), but
// the channel is not diagnosed (a public PX4 sample printed "residual 0 mG RMS: no gap").
TEST(CompassTerms, GivenALogWithNoFlight_WhenDiagnosed_ThenTheCompassIsNotDiagnosedAndSaysWhy) {
  logs::FlightLog log = Log171().log;
  ASSERT_TRUE(log.Has("armed"));
  for (double& a : log.MutableColumn(log.AddColumn("armed"))) a = 0.0;
  DiagnoseOptions o;
  o.bootstrap_samples = 50;
  o.channels = {"mag2"};
  auto rep = Diagnose(log, Log171().vehicle, o);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  for (const auto& c : rep->channels) EXPECT_NE(c.channel, "mag2") << c.headline;
  bool said = false;
  for (const auto& [ch, why] : rep->not_diagnosed) said = said || (ch == "mag2" && why.find("too few flight samples: 0") != std::string::npos);
  EXPECT_TRUE(said);
}

// A current the import judged unusable (units, or no power monitor: the flight median under 0.5 A
// per motor) drives no current family and no staleness: its fits would be numbers in the wrong unit
// (a public PX4 log's flat 0 A current read 15 mG/A current_hard_iron on its external compass).
TEST(CompassTerms, GivenAnUnusableCurrent_WhenDiagnosed_ThenNoCurrentFamilyIsFittedAndItSaysWhy) {
  logs::FlightLog log = Log171().log;
  log.meta["current_usable"] = false;
  log.meta["current_unusable_why"] = "current sensor unusable: units or no power monitor";
  DiagnoseOptions o;
  o.bootstrap_samples = 50;
  o.channels = {"mag2"};
  auto rep = Diagnose(log, Log171().vehicle, o);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = nullptr;
  for (const auto& c : rep->channels) {
    if (c.channel == "mag2") mag2 = &c;
  }
  ASSERT_NE(mag2, nullptr);
  bool per_motor = false;
  for (const auto& k : mag2->candidates) {
    EXPECT_NE(k.id, Effect::kCurrentHardIron) << k.effect;
    EXPECT_NE(k.id, Effect::kCurrentSoftIron) << k.effect;
    EXPECT_NE(k.id, Effect::kCurrentLag) << k.effect;
    // the output-driven families stay, in their own units: no conversion through the current
    per_motor = per_motor || k.id == Effect::kPerMotorCurrentHardIron;
    EXPECT_EQ(k.params.count("current_equivalent_uT_per_A"), 0u) << k.effect;
  }
  EXPECT_TRUE(per_motor);
  for (const auto& e : mag2->effects) EXPECT_NE(e.autopilot_unit, "mG/A") << e.effect;
  EXPECT_FALSE(mag2->timing.current_staleness.present);
  bool said = false;
  for (const auto& why : mag2->not_available) said = said || why.find("units or no power monitor") != std::string::npos;
  EXPECT_TRUE(said);
  ASSERT_TRUE(mag2->absolute_terms.has_value());
  EXPECT_EQ(mag2->absolute_terms->form, "throttle");
}

// A log flown with throttle compensation (COMPASS_MOTCT 1): MAG2's resolved current field replaces
// it, and the file says what the log had.
TEST(CompassTerms, GivenALogFlownWithThrottleCompensation_WhenMag2sCurrentFieldIsResolved_ThenCalibParmReplacesIt) {
  logs::FlightLog log = Log171().log;
  log.meta["compass_motct"] = 1;
  for (auto& c : log.meta["compasses"]) {
    if (c["column"] == "mag2") c["motor_compensation_mG"] = {0.0, 0.0, 0.0};
  }
  const realdata::FlightWindows w = realdata::FindFlightWindows(log);
  auto t = internal::FitCompassTerms(log, Log171().vehicle, 1, "mag2", w, 1);
  ASSERT_TRUE(t.ok()) << t.status().message();
  ASSERT_TRUE(t->term_fitted && t->term_resolved && t->term_plausible) << t->term_note;
  const ParamFiles files = CompassParamFiles({*t});
  EXPECT_NE(files.parm.find("\nCOMPASS_MOTCT 2\n"), std::string::npos) << files.parm;
  EXPECT_NE(files.parm.find("\nCOMPASS_MOT2_Y "), std::string::npos) << files.parm;
  EXPECT_NE(files.parm.find("replaced by the fitted current field (the log had COMPASS_MOTCT 1"), std::string::npos)
      << files.parm;
  EXPECT_NE(files.params.find("CAL_MAG_COMP_TYP"), std::string::npos) << files.params;
}

// A fit that saw no flight (every flight window a run on the ground, as a props-off run) writes no
// compensation and zeroes none: MAG2's resolved field of the same rows, flown, is written.
TEST(CompassTerms, GivenOnlyRunsOnTheGround_WhenMag2sFieldIsResolved_ThenNoCompensationIsWrittenOrZeroed) {
  const realdata::FlightWindows flown = realdata::FindFlightWindows(Log171().log);
  realdata::FlightWindows ground = flown;
  for (auto& w : ground.windows) w.on_ground = w.kind == "flight";
  auto f = internal::FitCompassTerms(Log171().log, Log171().vehicle, 1, "mag2", flown, 1);
  auto g = internal::FitCompassTerms(Log171().log, Log171().vehicle, 1, "mag2", ground, 1);
  ASSERT_TRUE(f.ok()) << f.status().message();
  ASSERT_TRUE(g.ok()) << g.status().message();
  ASSERT_TRUE(f->term_fitted && f->term_resolved && f->term_plausible) << f->term_note;
  EXPECT_TRUE(f->motor.action == "written" || f->motor.action == "replaced") << f->motor.action;
  EXPECT_NE(g->ground_run_note.find("on the ground"), std::string::npos) << g->ground_run_note;
  // kept, none, or no parameter file at all (the gate judges the fit without the unapplied term)
  for (const char* wrote : {"written", "replaced", "zeroed"}) EXPECT_NE(g->motor.action, wrote) << g->motor.comment;
}

// The external compass (MAG): no resolved current field, so no compensation line is written, and a
// log with none in force keeps none.
TEST(CompassTerms, GivenTheExternalCompass_WhenItsFieldIsNotResolved_ThenNoCompensationIsWritten) {
  const realdata::FlightWindows w = realdata::FindFlightWindows(Log171().log);
  auto t = internal::FitCompassTerms(Log171().log, Log171().vehicle, 0, "mag", w, 1);
  ASSERT_TRUE(t.ok()) << t.status().message();
  EXPECT_FALSE(t->term_resolved);
  const ParamFiles files = CompassParamFiles({*t});
  EXPECT_EQ(files.parm.find("\nCOMPASS_MOT"), std::string::npos) << files.parm;
  EXPECT_NE(files.parm.find("\nCOMPASS_OFS_X "), std::string::npos) << files.parm;
  EXPECT_NE(files.parm.find("not written"), std::string::npos) << files.parm;
}

// One acceptance gate for calibrate and gap (flight_fit.h FlightFitness_uT): a compass whose fit the
// gate rejects (here MAG2 with its x axis reading twice its value, a soft iron the model has no term for)
// gets no parameters in gap's calib.parm, and the file says why.
TEST(CompassTerms, GivenAFitCalibratesGateRejects_WhenParametersAreWritten_ThenThatCompassGetsNone) {
  logs::FlightLog log = Log171().log;
  std::vector<double>& x = log.MutableColumn(log.AddColumn("mag2_x_uT"));
  for (double& v : x) v *= 2.0;
  const realdata::FlightWindows w = realdata::FindFlightWindows(log);
  auto t = internal::FitCompassTerms(log, Log171().vehicle, 1, "mag2", w, 1);
  ASSERT_TRUE(t.ok()) << t.status().message();
  EXPECT_GT(t->fitness_uT, magnetics::kMaxFlightFitness_uT);
  EXPECT_FALSE(t->gate_accepted);
  const ParamFiles files = CompassParamFiles({*t});
  EXPECT_EQ(files.parm.find("\nCOMPASS_OFS2_X "), std::string::npos) << files.parm;
  // The undistorted compass passes the same gate and gets its offsets.
  auto good = internal::FitCompassTerms(Log171().log, Log171().vehicle, 1, "mag2", realdata::FindFlightWindows(Log171().log), 1);
  ASSERT_TRUE(good.ok()) << good.status().message();
  EXPECT_TRUE(good->gate_accepted) << good->fitness_uT;
  const ParamFiles both = CompassParamFiles({*t, *good});
  EXPECT_NE(both.parm.find("mag2: no parameters: fitness"), std::string::npos) << both.parm;
}

// A throttle effect's current equivalent only where the current carries it: inside the model's own
// current term (log171 MAG2: 6.5 [5.3, 7.7] mG/A), never outside it, never on an unusable current.
TEST(CompassTerms, GivenAThrottleEffectsCurrentEquivalent_WhenChecked_ThenItIsKeptOnlyInsideTheModelsCurrentTerm) {
  const realdata::FlightWindows w = realdata::FindFlightWindows(Log171().log);
  auto t = internal::FitCompassTerms(Log171().log, Log171().vehicle, 1, "mag2", w, 1);
  ASSERT_TRUE(t.ok()) << t.status().message();
  ASSERT_EQ(t->form, "current");
  EXPECT_EQ(internal::CurrentEquivalentRefusal(t, t->term_norm_uT), "");
  const std::string outside = internal::CurrentEquivalentRefusal(t, 0.5 * t->term_norm_ci95_uT[0]);
  EXPECT_NE(outside.find("follows the throttle, not the current"), std::string::npos) << outside;
  logs::FlightLog unusable = Log171().log;
  unusable.meta["current_usable"] = false;
  unusable.meta["current_unusable_why"] = "test: no power monitor";
  auto u = internal::FitCompassTerms(unusable, Log171().vehicle, 1, "mag2", w, 1);
  ASSERT_TRUE(u.ok()) << u.status().message();
  const std::string why = internal::CurrentEquivalentRefusal(u, t->term_norm_uT);
  EXPECT_NE(why.find("current is unusable"), std::string::npos) << why;
}

// The current's shift for the prediction: the in-flight model's own choice where it resolves its
// current term, else the throttle scan's; the model's delete-one-block choices all on one member of
// a 50 ms grid (the saturating selftest field, 256 ms stale: all at 250 ms) still range one grid step
// either side (the plug-in's range before: 250-250 ms, no spread at all).
TEST(CompassTerms, GivenTheModelsDeleteOneChoicesOnOneGridMember_WhenTheShiftIsAPlugIn_ThenItRangesAGridStepEitherSide) {
  CompassTerms t;
  t.form = "current";
  t.term_fitted = t.term_resolved = true;
  t.current_shift_s = 0.25;
  t.current_shift_range_s[0] = t.current_shift_range_s[1] = 0.25;
  realdata::LagEstimate scan;
  scan.value_s = 0.177;
  scan.ci95_s[0] = 0.167;
  scan.ci95_s[1] = 0.245;
  const std::vector<double> grid = {0.0, 0.05, 0.10, 0.15, 0.20, 0.25, 0.30, 0.35, 0.40, 0.45};
  const internal::CurrentShift s = internal::PredictionCurrentShift(Result<CompassTerms>(t), scan, 0.177, grid);
  EXPECT_DOUBLE_EQ(s.value_s, 0.25);
  EXPECT_DOUBLE_EQ(s.plug_in.value_s, 0.25);
  EXPECT_NEAR(s.plug_in.ci95_s[0], 0.20, 1e-12);
  EXPECT_NEAR(s.plug_in.ci95_s[1], 0.30, 1e-12);
  // A term the data do not resolve: the throttle scan's shift and interval.
  t.term_resolved = false;
  const internal::CurrentShift u = internal::PredictionCurrentShift(Result<CompassTerms>(t), scan, 0.177, grid);
  EXPECT_DOUBLE_EQ(u.value_s, 0.177);
  EXPECT_DOUBLE_EQ(u.plug_in.ci95_s[0], 0.167);
  EXPECT_DOUBLE_EQ(u.plug_in.ci95_s[1], 0.245);
}

}  // namespace
}  // namespace hexsim::gap
