// GIVEN the paper's hex on the simulated turntable, WHEN each calibration is learnt from the
// samples and evaluated on an independent level turn, THEN the heading errors have the shape of the
// paper's Table 1 (uncorrected 12.5/13.3/14.3°, traditional 2.5/5.0/7.6°, adaptive 2.4/2.5/2.6°).
#include <gtest/gtest.h>

#include "hexsim/common/paths.h"
#include "hexsim/common/yaml_reader.h"
#include "hexsim/magnetics/compensator.h"
#include "hexsim/magnetics/heading_error.h"
#include "hexsim/sim/turntable.h"
#include "hexsim/vehicle/vehicle_io.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim {
namespace {

struct Rig {
  vehicle::VehicleParams vehicle;
  sim::WorldParams world;
};

Rig LoadPaperRig() {
  Rig rig;
  auto vnode = YamlReader::LoadFile(std::string(HEXSIM_SOURCE_DIR) + "/worlds/vehicles/paper_hex.yaml");
  EXPECT_TRUE(vnode.ok());
  rig.vehicle = vehicle::ParseVehicle(*vnode, "paper_hex.yaml").value();
  auto wnode = YamlReader::LoadFile(std::string(HEXSIM_SOURCE_DIR) + "/worlds/environments/changchun.yaml");
  EXPECT_TRUE(wnode.ok());
  rig.world = sim::ParseWorld(*wnode, "changchun.yaml").value();
  return rig;
}

std::vector<magnetics::HeadingErrorRow> Evaluate(const magnetics::Compensator& c,
                                                 const std::vector<magnetics::MagSample>& turn) {
  auto rows = magnetics::EvaluateHeadingError(c, turn, magnetics::HeadingErrorOptions{});
  EXPECT_TRUE(rows.ok()) << rows.status().message();
  return *rows;
}

TEST(PaperTable1, GivenPaperHexWhenCalibratedThenHeadingErrorsHaveThePapersShape) {
  const Rig rig = LoadPaperRig();
  sim::TurntableOptions cal;
  cal.seed = 1;
  auto cal_rows = sim::RunTurntable(rig.vehicle, rig.world, cal);
  ASSERT_TRUE(cal_rows.ok()) << cal_rows.status().message();
  const auto samples = sim::ToMagSamples(*cal_rows, 0);

  sim::TurntableOptions eval;
  eval.planes = {"xy"};
  eval.seed = 7919;  // an independent turn
  auto eval_rows = sim::RunTurntable(rig.vehicle, rig.world, eval);
  ASSERT_TRUE(eval_rows.ok());
  const auto turn = sim::ToMagSamples(*eval_rows, 0);

  // The clamped currents are the paper's: ~0 / 32 / 53 A.
  const auto none = Evaluate(*magnetics::MakeNoneCompensator(), turn);
  ASSERT_EQ(none.size(), 3u);
  EXPECT_NEAR(none[1].mean_current_A, 32.0, 3.2);
  EXPECT_NEAR(none[2].mean_current_A, 53.0, 5.3);
  for (const auto& r : none) EXPECT_GE(r.max_abs_deg, 10.0) << "uncorrected at u=" << r.control_u;

  auto learn = [&](const std::string& m) {
    auto c = magnetics::LearnCompensator(m, samples, magnetics::LearnOptions{}, nullptr);
    EXPECT_TRUE(c.ok()) << m << ": " << c.status().message();
    return std::move(*c);
  };
  const auto traditional = Evaluate(*learn("traditional"), turn);
  EXPECT_GE(traditional[2].max_abs_deg, 2.0 * traditional[0].max_abs_deg);
  EXPECT_LT(traditional[0].max_abs_deg, traditional[1].max_abs_deg);
  EXPECT_LT(traditional[1].max_abs_deg, traditional[2].max_abs_deg);

  for (const char* m : {"adaptive", "adaptive-current", "compassmot", "px4-ls"}) {
    const auto adaptive = Evaluate(*learn(m), turn);
    for (const auto& r : adaptive) {
      EXPECT_LE(r.max_abs_deg, 3.0) << m << " at u=" << r.control_u;
      EXPECT_NEAR(r.max_abs_deg, adaptive[0].max_abs_deg, 0.5) << m << " at u=" << r.control_u;
    }
  }
}

}  // namespace
}  // namespace hexsim
