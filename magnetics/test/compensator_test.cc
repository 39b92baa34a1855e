#include "hexsim/magnetics/compensator.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "hexsim/common/rng.h"
#include "hexsim/common/yaml_reader.h"
#include "hexsim/magnetics/calib_io.h"
#include "hexsim/magnetics/heading_error.h"
#include "support/calib_synth.h"

namespace hexsim::magnetics {
namespace {

using Eigen::Vector3d;

std::vector<MagSample> PaperSamples(uint64_t seed, testing::SynthRig* rig_out = nullptr) {
  testing::SynthRig rig;
  rig.soft_iron = testing::TestSoftIron();
  RngStream rng(seed, "compensator_test");
  if (rig_out) *rig_out = rig;
  return testing::Turntable(rig, rng);
}

// The hexsim.calib/1 JSON of the report into *report_json when given (magnetics_io).
std::unique_ptr<Compensator> Learn(const std::string& method, const std::vector<MagSample>& s,
                                   nlohmann::json* report_json = nullptr) {
  LearnReport report;
  auto r = LearnCompensator(method, s, LearnOptions{}, &report);
  EXPECT_TRUE(r.ok()) << method << ": " << r.status().message();
  if (!r.ok()) return nullptr;
  if (report_json) *report_json = LearnReportToJson(report, **r);
  return std::move(r).value();
}

TEST(Compensator, GivenTheNameList_ThenItHoldsEveryMethodAndEachLearnsFromPaperTurntableData) {
  const auto samples = PaperSamples(1);
  for (const auto& name : CompensatorNames()) {
    nlohmann::json report;
    auto c = Learn(name, samples, &report);
    ASSERT_NE(c, nullptr);
    EXPECT_EQ(c->name(), name);
    for (const char* key : {"schema", "method", "accepted", "gate", "rms_residual_uT", "coverage", "params"}) {
      EXPECT_TRUE(report.contains(key)) << name << " report lacks " << key;
    }
    EXPECT_EQ(report["schema"], "hexsim.calib/1");
    EXPECT_TRUE(report["accepted"].get<bool>()) << name << ": " << report["gate"].dump();
  }
}

TEST(Compensator, GivenNone_WhenCorrecting_ThenTheReadingIsUnchanged) {
  const auto c = MakeNoneCompensator();
  const Vector3d H(1.5, -2.0, 40.0);
  EXPECT_EQ(c->Correct(H, {300, 53}), H);
}

// Every method corrects the ground samples to the Earth field's direction; the current-aware ones
// also the samples at control 300. Angle tolerance: noise σ over the field, a few σ, plus fit error.
TEST(Compensator, GivenPaperTurntableData_WhenCurrentAwareMethodsCorrect_ThenDirectionMatchesEarthAtEveryControl) {
  testing::SynthRig rig;
  const auto samples = PaperSamples(2, &rig);
  const double F = rig.earth_N_uT.norm();
  const double tol_rad = 5.0 * rig.noise_uT / F;
  for (const char* name : {"adaptive", "adaptive-current", "compassmot", "px4-ls"}) {
    auto c = Learn(name, samples);
    ASSERT_NE(c, nullptr);
    double worst = 0.0;
    for (const auto& s : samples) {
      const Vector3d m = c->Correct(s.mag_B_uT, {s.control_u, s.current_A});
      worst = std::max(worst, std::acos(std::min(1.0, m.normalized().dot(s.earth_B_uT.normalized()))));
    }
    EXPECT_LT(worst, tol_rad) << name;
  }
}

TEST(Compensator, GivenSamplesFromOnePlane_WhenLearning_ThenBadInputSaysSo) {
  testing::SynthRig rig;
  rig.planes = {"xy"};
  RngStream rng(3, "one_plane");
  const auto r = LearnCompensator("traditional", testing::Turntable(rig, rng), LearnOptions{}, nullptr);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kBadInput);
  EXPECT_NE(r.status().message().find("plane"), std::string::npos) << r.status().message();
}

TEST(Compensator, GivenTwoPlanesOnly_WhenLearning_ThenBadInputAskingForThree) {
  // Two circles do not determine an ellipsoid: a pencil of quadrics passes through them.
  testing::SynthRig rig;
  rig.planes = {"xy", "yz"};
  RngStream rng(12, "two_planes");
  const auto r = LearnCompensator("traditional", testing::Turntable(rig, rng), LearnOptions{}, nullptr);
  EXPECT_EQ(r.status().code(), StatusCode::kBadInput);
  EXPECT_NE(r.status().message().find("plane"), std::string::npos) << r.status().message();
}

TEST(Compensator, GivenAGateBoundTheDataViolates_WhenLearning_ThenTheCompensatorIsReturnedButTheReportRejectsIt) {
  LearnOptions o;
  o.ellipsoid.max_radius_uT = 40.0;  // the synthetic field is ≈ 52 µT
  LearnReport learnt;
  const auto r = LearnCompensator("adaptive", PaperSamples(13), o, &learnt);
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_FALSE(learnt.accepted());
  const nlohmann::json report = LearnReportToJson(learnt, **r);
  EXPECT_FALSE(report["accepted"].get<bool>());
  EXPECT_FALSE(report["gate"]["accepted"].get<bool>());
  EXPECT_NE(report["gate"]["failures"].get<std::string>().find("radius_uT"), std::string::npos) << report["gate"].dump();
}

TEST(Compensator, GivenTooFewSamples_WhenLearning_ThenBadInput) {
  testing::SynthRig rig;
  rig.angle_step_deg = 120.0;  // 3 per plane, 9 per control amount
  RngStream rng(4, "few");
  const auto r = LearnCompensator("adaptive", testing::Turntable(rig, rng), LearnOptions{}, nullptr);
  EXPECT_EQ(r.status().code(), StatusCode::kBadInput);
  EXPECT_NE(r.status().message().find("too few"), std::string::npos) << r.status().message();
}

TEST(Compensator, GivenANanReading_WhenLearning_ThenBadInputNamingTheSample) {
  auto samples = PaperSamples(5);
  samples[42].mag_B_uT.x() = std::numeric_limits<double>::quiet_NaN();
  const auto r = LearnCompensator("traditional", samples, LearnOptions{}, nullptr);
  EXPECT_EQ(r.status().code(), StatusCode::kBadInput);
  EXPECT_NE(r.status().message().find("sample 42"), std::string::npos) << r.status().message();
}

TEST(Compensator, GivenOneControlAmount_WhenLearningAdaptive_ThenBadInputAskingForMore) {
  testing::SynthRig rig;
  rig.controls_u = {0.0};
  RngStream rng(6, "one_control");
  const auto samples = testing::Turntable(rig, rng);
  for (const char* m : {"adaptive", "adaptive-current", "compassmot", "px4-ls"}) {
    const auto r = LearnCompensator(m, samples, LearnOptions{}, nullptr);
    EXPECT_EQ(r.status().code(), StatusCode::kBadInput) << m;
    EXPECT_NE(r.status().message().find("control amounts"), std::string::npos) << r.status().message();
  }
  EXPECT_TRUE(LearnCompensator("traditional", samples, LearnOptions{}, nullptr).ok());
}

TEST(Compensator, GivenAnUnknownMethod_WhenLearning_ThenBadInputListingTheNames) {
  const auto r = LearnCompensator("magic", PaperSamples(7), LearnOptions{}, nullptr);
  EXPECT_EQ(r.status().code(), StatusCode::kBadInput);
  EXPECT_NE(r.status().message().find("px4-ls"), std::string::npos);
}

TEST(Compensator, GivenTheCentresMoveInTheXYPlane_WhenLearningWithThePaperLineForm_ThenNumericalWhileDirectionVectorWorks) {
  testing::SynthRig rig;
  rig.soft_iron = testing::TestSoftIron();
  rig.d_uT_per_u = Vector3d(0.012, -0.008, 0.0);
  rig.noise_uT = 0.0;
  RngStream rng(8, "xy_line");
  const auto samples = testing::Turntable(rig, rng);
  LearnOptions paper;
  paper.line_form = LineForm::kPaper;
  // With noiseless data the centres' z varies only by the fit's round-off.
  paper.line.singular_tolerance = 1e-4;
  const auto r = LearnCompensator("adaptive", samples, paper, nullptr);
  EXPECT_EQ(r.status().code(), StatusCode::kNumerical) << r.status().message();
  EXPECT_TRUE(LearnCompensator("adaptive", samples, LearnOptions{}, nullptr).ok());
}

TEST(Compensator, GivenEveryMethod_WhenWrittenToYamlAndReadBack_ThenItCorrectsIdentically) {
  const auto samples = PaperSamples(9);
  for (const auto& name : CompensatorNames()) {
    auto c = Learn(name, samples);
    ASSERT_NE(c, nullptr);
    const std::string text = CompensatorToYamlText(*c);
    auto node = YamlReader::LoadString(text, "calib.yaml");
    ASSERT_TRUE(node.ok()) << node.status().message();
    auto back = CompensatorFromYaml(*node, "calib.yaml");
    ASSERT_TRUE(back.ok()) << name << ": " << back.status().message() << "\n" << text;
    EXPECT_EQ((*back)->name(), name);
    for (const CompensatorInput in : {CompensatorInput{0, 0.6}, CompensatorInput{250, 44.0}, CompensatorInput{450, 80.0}}) {
      const Vector3d H(20.0, -3.0, 60.0);
      EXPECT_LT((c->Correct(H, in) - (*back)->Correct(H, in)).norm(), 1e-9) << name;
    }
  }
}

TEST(Compensator, GivenACalibYamlMissingAField_WhenRead_ThenBadInputNamesFileLineAndField) {
  const std::string text = "schema: hexsim.calib/1\nmethod: traditional\nsoft_iron: [1, 1, 1]\n";
  auto node = YamlReader::LoadString(text, "calib.yaml");
  ASSERT_TRUE(node.ok());
  const auto r = CompensatorFromYaml(*node, "calib.yaml");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kBadInput);
  EXPECT_NE(r.status().message().find("calib.yaml:"), std::string::npos) << r.status().message();
  EXPECT_NE(r.status().message().find("hard_iron_uT"), std::string::npos) << r.status().message();
}

TEST(Compensator, GivenACalibYamlWithAnUnknownMethodOrKey_WhenRead_ThenBadInput) {
  for (const std::string text : {"schema: hexsim.calib/1\nmethod: magic\n",
                                 "schema: hexsim.calib/1\nmethod: none\nextra: 1\n",
                                 "schema: hexsim.calib/2\nmethod: none\n"}) {
    auto node = YamlReader::LoadString(text, "c.yaml");
    ASSERT_TRUE(node.ok());
    EXPECT_EQ(CompensatorFromYaml(*node, "c.yaml").status().code(), StatusCode::kBadInput) << text;
  }
}

TEST(CalibIo, GivenSamplesWrittenAsCsv_WhenParsed_ThenTheyRoundTrip) {
  const auto samples = PaperSamples(10);
  const auto parsed = ParseSamplesCsv(SamplesToCsv(samples), "samples.csv");
  ASSERT_TRUE(parsed.ok()) << parsed.status().message();
  ASSERT_EQ(parsed->size(), samples.size());
  for (size_t i = 0; i < samples.size(); ++i) {
    EXPECT_EQ((*parsed)[i].plane, samples[i].plane);
    EXPECT_EQ((*parsed)[i].mag_B_uT, samples[i].mag_B_uT);
    EXPECT_EQ((*parsed)[i].earth_B_uT, samples[i].earth_B_uT);
    EXPECT_NEAR((*parsed)[i].q_NB.angularDistance(samples[i].q_NB), 0.0, 1e-12);
  }
}

TEST(CalibIo, GivenACsvMissingAColumnOrWithABadNumber_WhenParsed_ThenBadInputNamesFileLineAndColumn) {
  const auto missing = ParseSamplesCsv("plane,control_u,current_A\nxy,0,0\n", "s.csv");
  EXPECT_EQ(missing.status().code(), StatusCode::kBadInput);
  EXPECT_NE(missing.status().message().find("s.csv:1: angle_deg"), std::string::npos) << missing.status().message();
  std::string text = SamplesToCsv(PaperSamples(11));
  text += "xy,0,0,abc,1,0,0,0,1,2,3,1,2,3\n";
  const auto bad = ParseSamplesCsv(text, "s.csv");
  EXPECT_EQ(bad.status().code(), StatusCode::kBadInput);
  EXPECT_NE(bad.status().message().find("angle_deg"), std::string::npos) << bad.status().message();
}

}  // namespace
}  // namespace hexsim::magnetics
