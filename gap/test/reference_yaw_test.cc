// The attitude reference's heading error in proportion to the current (reference_yaw, effects.h): an
// estimator that fuses a compass the current disturbs turns its heading with the current, and every
// compass predicted with that attitude reads the Earth field turned about down. Given such a
// reference, a clean external compass is not current-driven: the reference is; given a true
// attitude, an internal compass's own current field stays a current field (fixed in the body, where
// the reference's turn is fixed in NED: the flight yaws through every heading).
#include <cmath>
#include <fstream>
#include <string>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "support/gap_fixtures.h"

#include "hexsim/common/rng.h"
#include "hexsim/gap/diagnose.h"
#include "hexsim/gap/effects.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::gap {
namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

// The reference an estimator fusing a current-disturbed compass would log: q' = q_z(c·I)⊗q, its
// heading c·I ahead of the true one (I the logged battery current).
void TurnReferenceWithCurrent(logs::FlightLog* log, double c_deg_per_A) {
  const auto& I = log->Column("current_A");
  const size_t iw = static_cast<size_t>(log->ColumnIndex("q_w"));
  for (size_t i = 0; i < log->rows(); ++i) {
    const Eigen::Quaterniond q(log->At(i, iw), log->At(i, iw + 1), log->At(i, iw + 2), log->At(i, iw + 3));
    const double psi = std::isfinite(I[i]) ? c_deg_per_A * I[i] * kDegToRad : 0.0;
    const Eigen::Quaterniond qr = Eigen::Quaterniond(Eigen::AngleAxisd(psi, Eigen::Vector3d::UnitZ())) * q;
    const double v[4] = {qr.w(), qr.x(), qr.y(), qr.z()};
    for (size_t k = 0; k < 4; ++k) log->MutableColumn(iw + k)[i] = v[k];
  }
}

const EffectShare* FindEffect(const ChannelResult& c, Effect id) {
  for (const EffectShare& e : c.effects) {
    if (e.id == id) return &e;
  }
  return nullptr;
}

bool CurrentDriven(const ChannelResult& c) {
  for (const EffectShare& e : c.effects) {
    if (DrivenByCurrent(e.id)) return true;
  }
  return false;
}

// The estimator fused quad_x's internal compass mag2 (mag is external, on the mast).
DiagnoseOptions FusedMag2() {
  DiagnoseOptions o;
  o.contaminating_compass = "mag2";
  return o;
}

// Given a reference whose heading runs 0.3 deg/A ahead of the truth and a clean external compass,
// when diagnosed, then the external compass is not current-driven: reference_yaw is an effect with
// 0.3 deg/A in its interval, and a finding says the reference's heading moves with the current.
TEST(GapReferenceYaw, GivenAReferenceTurnedByTheCurrent_WhenDiagnosed_ThenTheExternalCompassBlamesTheReference) {
  constexpr double kC_deg_per_A = 0.3;
  gaptest::Flown f = gaptest::FlyInjected({}, 2901, "reference_yaw", "selftest_flight");
  TurnReferenceWithCurrent(&f.log, kC_deg_per_A);
  auto rep = Diagnose(f.log, f.trial.configured, FusedMag2());
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag = gaptest::FindChannel(*rep, "mag");
  ASSERT_NE(mag, nullptr) << Summary(*rep);
  EXPECT_FALSE(CurrentDriven(*mag)) << Summary(*rep);
  const EffectShare* ref = FindEffect(*mag, Effect::kReferenceYaw);
  ASSERT_NE(ref, nullptr) << Summary(*rep);
  EXPECT_EQ(mag->verdict, "reference_yaw") << Summary(*rep);
  EXPECT_EQ(ref->unit, "deg/A");
  // First order in the heading error (c·I up to ~8 deg: 1 − cos ≈ 1 %) and the replay's systematic
  // error (effects_test.cc: 5 % of the magnitude) beside the interval.
  EXPECT_LE(ref->ci95.lo - 0.05 * ref->magnitude, kC_deg_per_A) << Summary(*rep);
  EXPECT_GE(ref->ci95.hi + 0.05 * ref->magnitude, kC_deg_per_A) << Summary(*rep);
  bool said = false;
  for (const std::string& s : mag->findings) said = said || s.find("heading moves with the current") != std::string::npos;
  EXPECT_TRUE(said) << Summary(*rep);
}

// Given the true attitude and a 4 mG/A body-fixed current field on the internal compass, when
// diagnosed with the reference family built (the estimator named as fusing mag2), then the field is
// current_hard_iron with its size, and neither compass names the reference.
TEST(GapReferenceYaw, GivenABodyFixedCurrentFieldAndATrueAttitude_WhenDiagnosed_ThenItStaysACurrentField) {
  constexpr double kD_uT_per_A = 0.4;
  gaptest::Flown f = gaptest::FlyInjected({{"current_hard_iron", kD_uT_per_A}}, 2902, "reference_yaw", "selftest_flight");
  auto rep = Diagnose(f.log, f.trial.configured, FusedMag2());
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr) << Summary(*rep);
  EXPECT_EQ(mag2->verdict, "current_hard_iron") << Summary(*rep);
  const EffectShare* chi = FindEffect(*mag2, Effect::kCurrentHardIron);
  ASSERT_NE(chi, nullptr) << Summary(*rep);
  EXPECT_LE(chi->ci95.lo - 0.05 * chi->magnitude, kD_uT_per_A) << Summary(*rep);
  EXPECT_GE(chi->ci95.hi + 0.05 * chi->magnitude, kD_uT_per_A) << Summary(*rep);
  for (const ChannelResult& c : rep->channels) {
    EXPECT_EQ(FindEffect(c, Effect::kReferenceYaw), nullptr) << c.channel << ": " << Summary(*rep);
  }
}

// Given both at once, the internal compass's own field and the reference turned by the current,
// when diagnosed, then the internal compass is current-driven and the external one blames the
// reference (the two differ as the vehicle yaws).
TEST(GapReferenceYaw, GivenAnInternalFieldAndATurnedReference_WhenDiagnosed_ThenEachCompassGetsItsOwnCause) {
  constexpr double kC_deg_per_A = 0.3, kD_uT_per_A = 0.4;
  gaptest::Flown f = gaptest::FlyInjected({{"current_hard_iron", kD_uT_per_A}}, 2903, "reference_yaw", "selftest_flight");
  TurnReferenceWithCurrent(&f.log, kC_deg_per_A);
  auto rep = Diagnose(f.log, f.trial.configured, FusedMag2());
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag = gaptest::FindChannel(*rep, "mag");
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag, nullptr) << Summary(*rep);
  ASSERT_NE(mag2, nullptr) << Summary(*rep);
  EXPECT_TRUE(CurrentDriven(*mag2)) << Summary(*rep);
  EXPECT_NE(mag2->verdict, "reference_yaw") << Summary(*rep);
  EXPECT_FALSE(CurrentDriven(*mag)) << Summary(*rep);
  EXPECT_NE(FindEffect(*mag, Effect::kReferenceYaw), nullptr) << Summary(*rep);
}

// Adds d·I to compass `c`'s columns (sensor frame), d = size·u with u the unit direction, in
// compass c's sensor frame, of the Earth field's turn about down at the flight's mean attitude:
// R_SB·mean(R_NBᵀ)·(ẑ × B_N) (B_N's direction from the clean external compass `ref`).
void AddFieldAlongTheTurn(logs::FlightLog* log, const vehicle::VehicleParams& v, size_t ref, size_t c, double size_uT_per_A,
                          double noise_uT, RngStream* rng) {
  const auto& I = log->Column("current_A");
  const size_t iw = static_cast<size_t>(log->ColumnIndex("q_w"));
  const auto Rnb = [&](size_t i) {
    return Eigen::Quaterniond(log->At(i, iw), log->At(i, iw + 1), log->At(i, iw + 2), log->At(i, iw + 3)).normalized().toRotationMatrix();
  };
  const std::string pr = ref == 0 ? "mag" : "mag" + std::to_string(ref + 1), pc = "mag" + std::to_string(c + 1);
  const size_t rx = static_cast<size_t>(log->ColumnIndex(pr + "_x_uT")), cx = static_cast<size_t>(log->ColumnIndex(pc + "_x_uT"));
  const auto& er = v.compasses[ref].error;
  Eigen::Vector3d B_N = Eigen::Vector3d::Zero();
  Eigen::Matrix3d Rt = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < log->rows(); ++i) {
    const Eigen::Vector3d m(log->At(i, rx), log->At(i, rx + 1), log->At(i, rx + 2));
    if (!m.allFinite() || !(I[i] > 1.0)) continue;  // in the air
    B_N += Rnb(i) * (er.R_SB.transpose() * (m - er.hard_iron_uT));
    Rt += Rnb(i).transpose();
  }
  const Eigen::Vector3d u = (v.compasses[c].error.R_SB * Rt * Eigen::Vector3d::UnitZ().cross(B_N)).normalized();
  for (size_t i = 0; i < log->rows(); ++i) {
    if (!std::isfinite(I[i]) || !std::isfinite(log->At(i, cx))) continue;
    const Eigen::Vector3d e = rng->Normal3(noise_uT);
    for (size_t k = 0; k < 3; ++k) {
      const auto j = static_cast<Eigen::Index>(k);
      log->MutableColumn(cx + k)[i] += size_uT_per_A * u[j] * I[i] + e[j];
    }
  }
}

// Given a flight that holds one heading and a noisy internal compass whose own current field points
// along the reference's turn of the Earth field (the two regressors nearly one direction in the
// body; 2 mG/A is the turn of a 0.55 deg/A reference, inside reference_yaw's range, so the simpler
// one-parameter family competes), when diagnosed, then it stays a current field.
TEST(GapReferenceYaw, GivenAHeldHeadingAndAnInternalFieldAlongTheTurn_WhenDiagnosed_ThenItStaysACurrentField) {
  constexpr double kD_uT_per_A = 0.2, kNoise_uT = 1.5;
  gaptest::Flown f = gaptest::FlyInjected({}, 2904, "reference_yaw",
                                           // held heading: the reference's turn of the Earth field keeps one
                                           // direction in the body, as a body-fixed field does
                                           gaptest::HeldHeadingMission("held_heading"));
  RngStream rng(2904, "reference_yaw/noise");
  AddFieldAlongTheTurn(&f.log, f.trial.configured, 0, 1, kD_uT_per_A, kNoise_uT, &rng);
  auto rep = Diagnose(f.log, f.trial.configured, FusedMag2());
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr) << Summary(*rep);
  EXPECT_TRUE(CurrentDriven(*mag2)) << Summary(*rep);
  EXPECT_EQ(FindEffect(*mag2, Effect::kReferenceYaw), nullptr) << Summary(*rep);
}

// Given a 6-degree misalignment of the compass the estimator fused, whose heading the reference
// adopted (the reference turned about down by the misalignment's rotation about the body's z), when
// diagnosed, then the misalignment is named by its tilt angles alone, each inside its interval: the
// rotation about the vertical turned the reference with the compass and is not the compass's to fit
// (CompassReplayOptions::fused_by_reference).
TEST(GapReferenceYaw, GivenAMisalignedFusedCompass_WhenDiagnosed_ThenOnlyItsTiltIsFitted) {
  gaptest::Flown f = gaptest::FlyInjected({{"misalignment", 6.0}}, 2905, "reference_yaw", "selftest_flight");
  const auto& truth = f.trial.truth.vehicle.compasses[kSelftestCompass].error.R_SB;
  const auto& cfg = f.trial.configured.compasses[kSelftestCompass].error.R_SB;
  const Eigen::AngleAxisd aa(Eigen::Matrix3d(truth * cfg.transpose()));
  const Eigen::Vector3d phi_deg = aa.axis() * aa.angle() / kDegToRad;
  // The reference's heading follows the compass's: a yaw of φz (body z ≈ down in level flight).
  const size_t iw = static_cast<size_t>(f.log.ColumnIndex("q_w"));
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(phi_deg.z() * kDegToRad, Eigen::Vector3d::UnitZ()));
  for (size_t i = 0; i < f.log.rows(); ++i) {
    const Eigen::Quaterniond q(f.log.At(i, iw), f.log.At(i, iw + 1), f.log.At(i, iw + 2), f.log.At(i, iw + 3));
    const Eigen::Quaterniond qr = turn * q;
    const double v[4] = {qr.w(), qr.x(), qr.y(), qr.z()};
    for (size_t k = 0; k < 4; ++k) f.log.MutableColumn(iw + k)[i] = v[k];
  }
  auto rep = Diagnose(f.log, f.trial.configured, FusedMag2());
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr) << Summary(*rep);
  EXPECT_TRUE(mag2->reference_contaminated);
  EXPECT_TRUE(gaptest::InEffects(*mag2, "misalignment")) << Summary(*rep);
  const CandidateResult* mis = gaptest::FindCandidate(*mag2, "misalignment");
  ASSERT_NE(mis, nullptr) << Summary(*rep);
  EXPECT_EQ(mis->params.count("phi_z_deg"), 0U) << Summary(*rep);
  const char* names[2] = {"phi_x_deg", "phi_y_deg"};
  for (int k = 0; k < 2; ++k) {
    ASSERT_EQ(mis->params.count(names[k]), 1U) << names[k];
    const auto& ci = mis->ci95.at(names[k]);
    // The replay's systematic error (effects_test.cc: 5 % of the magnitude) beside the interval.
    EXPECT_LE(ci.lo - 0.05 * mis->magnitude, phi_deg[k]) << names[k] << ": " << Summary(*rep);
    EXPECT_GE(ci.hi + 0.05 * mis->magnitude, phi_deg[k]) << names[k] << ": " << Summary(*rep);
  }
}

}  // namespace
}  // namespace hexsim::gap
