// Instructions per physics step, full stack against bare ODE, counted by callgrind: unlike time on a
// shared machine, the count does not move with the load (the same binary and input give the same
// count to a few parts in 10⁴). Only the steps themselves are instrumented:
//
//   valgrind --tool=callgrind --instr-atstart=no --callgrind-out-file=full.out build/bench/sim_instructions full
//   valgrind --tool=callgrind --instr-atstart=no --callgrind-out-file=bare.out build/bench/sim_instructions bare
//
// "Collected" (or callgrind_annotate's PROGRAM TOTALS) / 10 000 is the count per step; bare/full is
// the full stack's speed as a fraction of bare ODE by instruction count (BM_FullStackInAir/1/1 and
// BM_BareOdeInAir of bench_sim: default_hex, square's legs after take-off, ESKF, 100 Hz log).
// Arguments: full|bare [truth|eskf] [log|nolog]. Without valgrind it just runs the steps.
#include <cstdio>
#include <cstring>

#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#else
#define CALLGRIND_START_INSTRUMENTATION
#define CALLGRIND_STOP_INSTRUMENTATION
#endif

#include "hexsim/common/paths.h"
#include "hexsim/sim/rigid_body.h"
#include "hexsim/sim/run_config.h"
#include "hexsim/sim/simulation.h"
#include "hexsim/vehicle/vehicle_io.h"

namespace {

constexpr int kSteps = 10000;  // 10 s at 1 kHz, as BM_FullStackInAir
constexpr double kDt_s = 0.001;

int Usage() {
  std::fprintf(stderr, "usage: sim_instructions full|bare [truth|eskf] [log|nolog]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || (std::strcmp(argv[1], "full") != 0 && std::strcmp(argv[1], "bare") != 0)) return Usage();
  const bool bare = std::strcmp(argv[1], "bare") == 0;
  hexsim::sim::RunRequest req;
  req.mission = "square";
  req.vehicle = "default_hex";
  req.world = "default";
  req.estimator = argc > 2 ? argv[2] : "eskf";
  req.duration_s = 60.0;
  auto setup = hexsim::sim::LoadRunSetup(req);
  if (!setup.ok()) {
    std::fprintf(stderr, "sim_instructions: %s\n", setup.status().message().c_str());
    return 2;
  }
  setup->options.write_log = !(argc > 3 && std::strcmp(argv[3], "nolog") == 0);
  if (bare) {  // BM_BareOdeInAir's body and force
    auto vp = hexsim::vehicle::LoadVehicleFile(*hexsim::ResolveWorldFile("vehicles", "default_hex"));
    if (!vp.ok()) {
      std::fprintf(stderr, "sim_instructions: %s\n", vp.status().message().c_str());
      return 2;
    }
    hexsim::sim::EnsureOdeInitialised();
    const hexsim::sim::RigidBodyParams bp = hexsim::sim::BodyParamsFor(*vp, setup->world, 0.0);
    hexsim::sim::BodyState start;
    start.p_N_m = Eigen::Vector3d(0, 0, -10);
    start.v_N_mps = Eigen::Vector3d(5, 0, 0);
    hexsim::sim::RigidBodyWorld body(bp, start, /*ground=*/true);
    const Eigen::Vector3d hover_B_N(0.0, 0.0, -bp.mass_kg * bp.gravity_mps2);
    double sum_D_m = 0.0;
    CALLGRIND_START_INSTRUMENTATION;
    for (int i = 0; i < kSteps; ++i) {
      body.AddForce_B(hover_B_N);
      body.Step(kDt_s);
      sum_D_m += body.State().p_N_m.z();
    }
    CALLGRIND_STOP_INSTRUMENTATION;
    std::printf("bare ODE: %d steps, mean D %.6f m\n", kSteps, sum_D_m / kSteps);
    return 0;
  }
  auto sim = hexsim::sim::Simulation::Create(*setup);
  if (!sim.ok()) {
    std::fprintf(stderr, "sim_instructions: %s\n", sim.status().message().c_str());
    return 2;
  }
  while ((*sim)->Step() && -(*sim)->true_state().p_N_m.z() < 9.5) {
  }
  CALLGRIND_START_INSTRUMENTATION;
  for (int i = 0; i < kSteps; ++i) {
    if (!(*sim)->Step()) {
      std::fprintf(stderr, "sim_instructions: the run ended in the counted window\n");
      return 1;
    }
  }
  CALLGRIND_STOP_INSTRUMENTATION;
  const auto out = (*sim)->Finish();
  std::printf("full stack (%s, %s): %d steps, yaw error max %.6f deg\n", req.estimator.c_str(),
              setup->options.write_log ? "log" : "no log", kSteps, out.summary.yaw_error_deg.max);
  return 0;
}
