// The heading a compass's current field turns (verdict.h HeadingTurnOf): a field fixed in the body
// turns the heading by an amount that depends on the heading, so it is taken over a full turn of
// heading (CONTRACTS' heading error), not over the few headings a log happens to fly.
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
namespace heading_turn_test {

// Adds to mag2 white noise (noise_uT per axis) and a current field d·I, zero with the motors off,
// whose horizontal part lies along the Earth field's horizontal part at the flight's mean attitude
// (in the sensor frame: R_SB·mean(R_NBᵀ)·B_h,N, B_N from the clean external compass mag), plus as
// large a part along the body's down axis: at the heading held it barely turns the heading, at
// others by up to |d_h|·I/|B_h|. Returns |d_h|/|B_h|·mean(I)/√2, the turn's RMS over a full turn of
// heading (radians).
double AddFieldAlongTheEarthField(logs::FlightLog* log, const vehicle::VehicleParams& v, double d_h_uT_per_A,
                                  double noise_uT, RngStream* rng) {
  const auto& I = log->Column("current_A");
  const size_t iw = static_cast<size_t>(log->ColumnIndex("q_w"));
  const auto Rnb = [&](size_t i) {
    return Eigen::Quaterniond(log->At(i, iw), log->At(i, iw + 1), log->At(i, iw + 2), log->At(i, iw + 3)).normalized().toRotationMatrix();
  };
  const size_t rx = static_cast<size_t>(log->ColumnIndex("mag_x_uT")), cx = static_cast<size_t>(log->ColumnIndex("mag2_x_uT"));
  const auto& er = v.compasses[0].error;
  Eigen::Vector3d B_N = Eigen::Vector3d::Zero();
  Eigen::Matrix3d Rt = Eigen::Matrix3d::Zero();
  double I_sum = 0;
  int n = 0;
  for (size_t i = 0; i < log->rows(); ++i) {
    const Eigen::Vector3d m(log->At(i, rx), log->At(i, rx + 1), log->At(i, rx + 2));
    if (!m.allFinite() || !(I[i] > 1.0)) continue;  // in the air
    B_N += Rnb(i) * (er.R_SB.transpose() * (m - er.hard_iron_uT));
    Rt += Rnb(i).transpose();
    I_sum += I[i];
    ++n;
  }
  if (n == 0) return 0.0;
  B_N /= n;
  const Eigen::Vector3d B_h(B_N.x(), B_N.y(), 0.0);
  const Eigen::Matrix3d& R_SB = v.compasses[1].error.R_SB;
  const Eigen::Vector3d d = d_h_uT_per_A * (R_SB * Rt * B_h).normalized() + d_h_uT_per_A * (R_SB * Eigen::Vector3d::UnitZ());
  for (size_t i = 0; i < log->rows(); ++i) {
    if (!std::isfinite(I[i]) || !std::isfinite(log->At(i, cx))) continue;
    const Eigen::Vector3d e = rng->Normal3(noise_uT);
    for (size_t k = 0; k < 3; ++k) {
      const auto j = static_cast<Eigen::Index>(k);
      log->MutableColumn(cx + k)[i] += d[j] * I[i] + e[j];
    }
  }
  return d_h_uT_per_A * (I_sum / n) / (std::sqrt(2.0) * B_h.norm());
}

// Given a flight that holds one heading and a noisy internal compass (3 µT per axis) whose current
// field, 1.5 mG/A across and 1.5 mG/A down, lies along the Earth field at that heading (its
// variation a few per cent of the noise power, not material by it; at the heading held it turns
// the heading by almost nothing, at a quarter turn by several degrees), when diagnosed, then the
// field is material by the heading it turns over a full turn of heading, said so, with the turn
// near |d_h|·I/(√2·|B_h|) and its low end above the rule.
TEST(GapHeadingTurn, GivenAHeldHeadingAndAFieldAlongTheEarthField_WhenDiagnosed_ThenItTurnsTheHeadingOverAFullTurn) {
  constexpr double kDh_uT_per_A = 0.15, kNoise_uT = 3.0;
  gaptest::Flown f = gaptest::FlyInjected({}, 3101, "heading_turn", gaptest::HeldHeadingMission("held_heading_turn"));
  RngStream rng(3101, "heading_turn/noise");
  const double turn_rad = AddFieldAlongTheEarthField(&f.log, f.trial.configured, kDh_uT_per_A, kNoise_uT, &rng);
  ASSERT_GT(turn_rad, 0.0);
  DiagnoseOptions o;
  o.channels = {"mag2"};
  auto rep = Diagnose(f.log, f.trial.configured, o);
  ASSERT_TRUE(rep.ok()) << rep.status().message();
  const ChannelResult* mag2 = gaptest::FindChannel(*rep, "mag2");
  ASSERT_NE(mag2, nullptr);
  bool current = false;
  for (const EffectShare& e : mag2->effects) current = current || DrivenByCurrent(e.id);
  EXPECT_TRUE(current) << Summary(*rep);
  std::string said;
  for (const std::string& s : mag2->findings) {
    if (s.find("over a full turn of heading") != std::string::npos) said = s;
  }
  ASSERT_FALSE(said.empty()) << Summary(*rep);
  // "... turns: X deg RMS over a full turn ..." within a third of the injected turn.
  const size_t at = said.find("turns: ");
  ASSERT_NE(at, std::string::npos) << said;
  const double deg = std::stod(said.substr(at + 7));
  const double want = turn_rad * 180.0 / 3.14159265358979323846;
  EXPECT_NEAR(deg, want, want / 3.0) << said;
}

}  // namespace heading_turn_test
}  // namespace hexsim::gap
