// Speed of the simulator: the full closed loop (1 kHz physics, sensors, estimator, controller, log
// at 100 Hz) as a real-time factor, and one physics step (ODE rigid body + powertrain + rotor wrench).
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>

#include "hexsim/common/paths.h"
#include "hexsim/sim/rigid_body.h"
#include "hexsim/sim/run_config.h"
#include "hexsim/sim/simulation.h"
#include "hexsim/vehicle/powertrain.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace {

using hexsim::sim::RunRequest;

constexpr double kSimSeconds = 20.0;  // per iteration; the square's first 20 s: take-off and a leg

hexsim::sim::RunSetup Setup(const char* estimator, bool write_log) {
  RunRequest req;
  req.mission = "square";
  req.vehicle = "default_hex";
  req.world = "default";
  req.estimator = estimator;
  req.duration_s = kSimSeconds;
  auto setup = hexsim::sim::LoadRunSetup(req);
  if (!setup.ok()) {
    std::fprintf(stderr, "bench_sim: %s\n", setup.status().message().c_str());
    std::abort();
  }
  setup->options.write_log = write_log;
  return *setup;
}

// args: 0 = truth, 1 = eskf; second arg: write the log (1) or not (0).
void BM_FullStack(benchmark::State& state) {
  const char* estimator = state.range(0) == 1 ? "eskf" : "truth";
  const auto setup = Setup(estimator, state.range(1) == 1);
  double sim_s = 0.0;
  for (auto _ : state) {
    auto out = hexsim::sim::RunMission(setup);
    benchmark::DoNotOptimize(out.summary);
    sim_s += kSimSeconds;
  }
  state.SetLabel(std::string(estimator) + (state.range(1) ? ", log 100 Hz" : ", no log"));
  // Simulated seconds per wall second: the real-time factor.
  state.counters["realtime_x"] = benchmark::Counter(sim_s, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_FullStack)->Args({0, 1})->Args({1, 1})->Args({1, 0})->Unit(benchmark::kMillisecond)->UseRealTime();

// One 1 kHz physics step of a hovering vehicle: powertrain, rotor wrench, drag, ODE step (with the
// ground plane's collision test, body in the air: no contacts).
void BM_PhysicsStep(benchmark::State& state) {
  auto path = hexsim::ResolveWorldFile("vehicles", "default_hex");
  auto vp = hexsim::vehicle::LoadVehicleFile(*path);
  if (!vp.ok()) {
    state.SkipWithError(vp.status().message().c_str());
    return;
  }
  hexsim::sim::EnsureOdeInitialised();
  hexsim::sim::RigidBodyParams bp;
  bp.mass_kg = vp->mass_kg;
  bp.inertia_kgm2 = vp->inertia_kgm2;
  hexsim::sim::BodyState start;
  start.p_N_m = Eigen::Vector3d(0, 0, -10);
  const bool ground = state.range(0) == 1;
  hexsim::sim::RigidBodyWorld body(bp, start, ground);
  auto pt = hexsim::vehicle::InitialPowertrainState(*vp);
  const std::vector<double> commands(vp->rotors.size(), 0.55);
  constexpr double kDt_s = 0.001;
  for (auto _ : state) {
    const auto s = body.State();
    const auto power = hexsim::vehicle::StepPowertrain(*vp, commands, kDt_s, &pt);
    const auto w = hexsim::vehicle::RotorWrench(*vp, pt.omega_radps, s.w_B_radps);
    body.AddForce_B(w.force_B_N);
    body.AddTorque_B(w.torque_B_Nm);
    body.Step(kDt_s);
    benchmark::DoNotOptimize(power.battery_A);
    if (body.State().p_N_m.norm() > 1e4) body.SetState(start);  // keep it in range on long runs
  }
  state.SetLabel(ground ? "with ground plane" : "free body");
}
BENCHMARK(BM_PhysicsStep)->Arg(0)->Arg(1);

}  // namespace

BENCHMARK_MAIN();
