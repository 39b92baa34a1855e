// The selftest's forms beyond the library's names: what each injects into a log, and what names it right.
#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "../src/selftest_real.h"
#include "hexsim/common/rng.h"

namespace hexsim::gap::internal {
namespace {

// 120 s at 100 Hz: a current stepping between 5 and 25 A every 10 s, the voltage sagging 0.02 V/A,
// a throttle following the current, and a compass reading a constant field.
logs::FlightLog SyntheticLog() {
  logs::FlightLog log;
  for (const char* c : {"t_s", "current_A", "voltage_V", "control_u", "mag2_x_uT", "mag2_y_uT", "mag2_z_uT"}) log.AddColumn(c);
  for (int i = 0; i < 12000; ++i) {
    const double t = 0.01 * i;
    const double I = (static_cast<int>(t / 10.0) % 2 == 0) ? 5.0 : 25.0;
    log.AppendRow();
    const double row[] = {t, I, 16.0 - 0.02 * I - 0.005 * t, 0.3 + 0.02 * I, 20.0, 0.0, 40.0};
    for (size_t c = 0; c < 7; ++c) log.Set(c, row[c]);
  }
  return log;
}

// The field a form added to mag2, per row.
std::vector<Vec3> Added(const logs::FlightLog& before, const logs::FlightLog& after) {
  std::vector<Vec3> d;
  for (size_t i = 0; i < before.rows(); ++i) {
    d.emplace_back(after.Column("mag2_x_uT")[i] - before.Column("mag2_x_uT")[i],
                   after.Column("mag2_y_uT")[i] - before.Column("mag2_y_uT")[i],
                   after.Column("mag2_z_uT")[i] - before.Column("mag2_z_uT")[i]);
  }
  return d;
}

TEST(GapSelftestForms, GivenACurrentSensorThatDropsOut_WhenInjected_ThenTheFieldFollowsTheTrueCurrentAndTheLogReadsZeroOverSpans) {
  const logs::FlightLog clean = SyntheticLog();
  logs::FlightLog log = clean;
  RngStream rng(7, "forms");
  ASSERT_TRUE(InjectBeyondLibrary(&log, 1, "current_dropout", &rng).ok());
  const auto& I_true = clean.Column("current_A");
  const auto& I_log = log.Column("current_A");
  const long zeros = std::count(I_log.begin(), I_log.end(), 0.0);
  EXPECT_GE(zeros, static_cast<long>(0.12 * static_cast<double>(log.rows())));  // about 15 %, spans overlap
  // The field is k·I of the true current (not of the logged one): 25 A against 5 A, 5:1.
  const std::vector<Vec3> d = Added(clean, log);
  const double ratio = d[1500].norm() / d[500].norm();  // t = 15 s (25 A) over t = 5 s (5 A)
  EXPECT_NEAR(ratio, I_true[1500] / I_true[500], 1e-9);
}

TEST(GapSelftestForms, GivenACurrentSensorThatClips_WhenInjected_ThenTheLoggedCurrentStopsAtItsSixtiethPercentile) {
  const logs::FlightLog clean = SyntheticLog();
  logs::FlightLog log = clean;
  RngStream rng(8, "forms");
  ASSERT_TRUE(InjectBeyondLibrary(&log, 1, "current_clipped", &rng).ok());
  const auto& I_log = log.Column("current_A");
  // The 60th percentile of a current half at 5 A, half at 25 A is 25 A; every sample at or below it.
  EXPECT_LE(*std::max_element(I_log.begin(), I_log.end()), 25.0);
  const std::vector<Vec3> d = Added(clean, log);
  EXPECT_GT(d[1500].norm(), 4.0 * d[500].norm());  // the field still follows the true current
}

TEST(GapSelftestForms, GivenALaggedPowerLawField_WhenInjected_ThenItRisesThroughItsLagAfterACurrentStep) {
  const logs::FlightLog clean = SyntheticLog();
  logs::FlightLog log = clean;
  RngStream rng(9, "forms");
  auto truth = InjectBeyondLibrary(&log, 1, "current_power_lag", &rng);
  ASSERT_TRUE(truth.ok());
  ASSERT_TRUE(std::isfinite(truth->lag_s));
  EXPECT_GE(truth->lag_s, 0.2);
  EXPECT_LE(truth->lag_s, 0.8);
  const std::vector<Vec3> d = Added(clean, log);
  // The current steps to 25 A at t = 10 s: one time constant later the field has covered 1 − 1/e of
  // its rise in I_τ (before the power law), so it lies strictly between its two steady values.
  const size_t step = 1000, later = step + static_cast<size_t>(truth->lag_s / 0.01);
  EXPECT_GT(d[later].norm(), d[step - 1].norm() * 1.5);
  EXPECT_LT(d[later].norm(), d[step + 900].norm() * 0.95);
  // Every added vector along one direction.
  EXPECT_NEAR(std::fabs(d[later].normalized().dot(d[step + 900].normalized())), 1.0, 1e-9);
}

TEST(GapSelftestForms, GivenAnOffsetLaggingTheLoggedTemperature_WhenInjected_ThenTheLogGainsTheImuTemperature) {
  const logs::FlightLog clean = SyntheticLog();
  logs::FlightLog log = clean;
  RngStream rng(10, "forms");
  auto truth = InjectBeyondLibrary(&log, 1, "lagged_temperature", &rng);
  ASSERT_TRUE(truth.ok());
  ASSERT_TRUE(log.Has("imu_temp_C"));
  EXPECT_NEAR(log.Column("imu_temp_C").back(), 25.0 + 20.0 * (1 - std::exp(-119.99 / 40.0)), 0.3);
  EXPECT_GE(truth->lag_s, 30.0);
  EXPECT_LE(truth->lag_s, 60.0);
}

TEST(GapSelftestForms, GivenAVerticalAxisScale_WhenInjected_ThenOnlyTheZAxisReadsAFewPerCentLargeWhateverTheCurrent) {
  const logs::FlightLog clean = SyntheticLog();
  logs::FlightLog log = clean;
  RngStream rng(12, "forms");
  ASSERT_TRUE(InjectBeyondLibrary(&log, 1, "vertical_axis_scale", &rng).ok());
  const std::vector<Vec3> d = Added(clean, log);
  const double s = log.Column("mag2_z_uT")[0] / clean.Column("mag2_z_uT")[0] - 1.0;
  EXPECT_GE(s, 0.05);
  EXPECT_LE(s, 0.15);
  for (size_t i = 0; i < d.size(); i += 97) {
    EXPECT_EQ(d[i].x(), 0.0);
    EXPECT_EQ(d[i].y(), 0.0);
    // A static gain: the same at 5 A and at 25 A (a current-driven field would step with it).
    EXPECT_NEAR(d[i].z(), s * clean.Column("mag2_z_uT")[i], 1e-9);
  }
  EXPECT_NEAR(d[500].z(), d[1500].z(), 1e-9);
  const LogForm* f = FindForm("vertical_axis_scale");
  ASSERT_NE(f, nullptr);
  EXPECT_NE(std::find(f->named_right.begin(), f->named_right.end(), Effect::kScaleError), f->named_right.end());
  for (Effect e : f->named_right) EXPECT_FALSE(DrivenByCurrent(e));  // a static gain is not current-driven
}

TEST(GapSelftestForms, GivenAnUnknownFormOrALogWithoutCurrent_WhenInjected_ThenItIsBadInput) {
  logs::FlightLog log = SyntheticLog();
  RngStream rng(11, "forms");
  EXPECT_EQ(InjectBeyondLibrary(&log, 1, "no_such_form", &rng).status().code(), StatusCode::kBadInput);
  logs::FlightLog bare;
  bare.AddColumn("t_s");
  EXPECT_EQ(InjectBeyondLibrary(&bare, 1, "current_dropout", &rng).status().code(), StatusCode::kBadInput);
}

TEST(GapSelftestForms, GivenTheRegistry_WhenAFormIsLookedUp_ThenOnlyTheEffectItIsAFormOfNamesItRight) {
  ASSERT_EQ(BeyondLibraryForms().size(), 7u);
  const LogForm* lag = FindForm("current_power_lag");
  ASSERT_NE(lag, nullptr);
  EXPECT_NE(std::find(lag->named_right.begin(), lag->named_right.end(), Effect::kCurrentHardIron), lag->named_right.end());
  EXPECT_EQ(std::find(lag->named_right.begin(), lag->named_right.end(), Effect::kScaleError), lag->named_right.end());
  const LogForm* temp = FindForm("lagged_temperature");
  ASSERT_NE(temp, nullptr);
  EXPECT_EQ(temp->named_right, std::vector<Effect>{Effect::kTemperatureDrift});
  // Out-of-library families have no right name: only an honest "not confident" is right.
  for (const LogForm& f : OutOfLibraryFamilies()) EXPECT_TRUE(f.named_right.empty()) << f.name;
  EXPECT_EQ(FindForm("no_such_form"), nullptr);
}

}  // namespace
}  // namespace hexsim::gap::internal
