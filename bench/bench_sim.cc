// Speed of the simulator, every full-stack figure beside its bare-physics counterpart measured in
// the same process run (the machine is shared: only ratios taken side by side mean anything).
//
//   BM_BareOdeInAir      the vehicle's rigid body (ODE, ground plane present, no contact) in the
//                        air under a constant hover force: no powertrain, no sensors, no autopilot.
//   BM_FullStackInAir    the whole closed loop (1 kHz physics + powertrain + rotor wrench + drag,
//                        sensors, estimator, controller, mixer, observers, 100 Hz log) flying the
//                        square's legs after take-off: the same body in the same air.
//   BM_FullStack         the square's first 20 s from the ground (take-off included), as before.
//   BM_PhysicsStep       one physics step with the powertrain and rotor wrench (no autopilot).
// After the run, one line per full-stack case gives its speed as a fraction of BM_BareOdeInAir's
// (bare time per step / full-stack time per step; 1 = as fast as bare physics), in wall time and in
// CPU time (on a shared machine only the CPU ratio is stable).
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>

#include "hexsim/common/paths.h"
#include "hexsim/sim/rigid_body.h"
#include "hexsim/sim/run_config.h"
#include "hexsim/sim/simulation.h"
#include "hexsim/vehicle/powertrain.h"
#include "hexsim/vehicle/rotor_wrench.h"
#include "hexsim/vehicle/vehicle_io.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace {

using hexsim::sim::RunRequest;

constexpr double kSimSeconds = 20.0;    // BM_FullStack: the square's first 20 s
constexpr double kInAirSeconds = 10.0;  // BM_FullStackInAir: timed seconds after take-off
constexpr double kPhysicsDt_s = 0.001;

hexsim::sim::RunSetup Setup(const char* estimator, bool write_log, double duration_s) {
  RunRequest req;
  req.mission = "square";
  req.vehicle = "default_hex";
  req.world = "default";
  req.estimator = estimator;
  req.duration_s = duration_s;
  auto setup = hexsim::sim::LoadRunSetup(req);
  if (!setup.ok()) {
    std::fprintf(stderr, "bench_sim: %s\n", setup.status().message().c_str());
    std::abort();
  }
  setup->options.write_log = write_log;
  return *setup;
}

const char* EstimatorArg(int64_t v) { return v == 1 ? "eskf" : "truth"; }

std::string Label(const char* estimator, bool log) { return std::string(estimator) + (log ? ", log 100 Hz" : ", no log"); }

// args: estimator 0 = truth, 1 = eskf; log 0/1.
void BM_FullStack(benchmark::State& state) {
  const char* estimator = EstimatorArg(state.range(0));
  const auto setup = Setup(estimator, state.range(1) == 1, kSimSeconds);
  for (auto _ : state) {
    auto out = hexsim::sim::RunMission(setup);
    benchmark::DoNotOptimize(out.summary);
  }
  state.SetLabel(Label(estimator, state.range(1) == 1));
  state.counters["realtime_x"] =
      benchmark::Counter(kSimSeconds * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["steps"] = kSimSeconds / kPhysicsDt_s;
}
BENCHMARK(BM_FullStack)->Args({0, 1})->Args({1, 1})->Args({1, 0})->Unit(benchmark::kMillisecond)->UseRealTime();

// The closed loop in the air: take-off is flown untimed, then kInAirSeconds of the square's legs.
void BM_FullStackInAir(benchmark::State& state) {
  const char* estimator = EstimatorArg(state.range(0));
  const auto setup = Setup(estimator, state.range(1) == 1, 60.0);
  const auto steps = static_cast<int64_t>(kInAirSeconds / kPhysicsDt_s);
  for (auto _ : state) {
    state.PauseTiming();
    auto sim = hexsim::sim::Simulation::Create(setup).value();
    while (sim->Step() && -sim->true_state().p_N_m.z() < 9.5) {
    }
    state.ResumeTiming();
    bool ran = !sim->finished();
    for (int64_t i = 0; i < steps && ran; ++i) ran = sim->Step();
    if (!ran) {
      state.SkipWithError("the run ended before or in the timed window");
      break;
    }
    state.PauseTiming();
    benchmark::DoNotOptimize(sim->Finish().summary);
    sim.reset();
    state.ResumeTiming();
  }
  state.SetLabel(Label(estimator, state.range(1) == 1));
  state.counters["realtime_x"] =
      benchmark::Counter(kInAirSeconds * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["steps"] = static_cast<double>(steps);
}
BENCHMARK(BM_FullStackInAir)
    ->Args({0, 1})
    ->Args({1, 1})
    ->Args({1, 0})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

hexsim::vehicle::VehicleParams DefaultHex() {
  auto path = hexsim::ResolveWorldFile("vehicles", "default_hex");
  auto vp = hexsim::vehicle::LoadVehicleFile(*path);
  if (!vp.ok()) {
    std::fprintf(stderr, "bench_sim: %s\n", vp.status().message().c_str());
    std::abort();
  }
  return *vp;
}

// The same body as the simulation's (mass, inertia, landing-gear box, ground plane) at 10 m,
// held by a constant force equal to its weight: ODE alone.
void BM_BareOdeInAir(benchmark::State& state) {
  const auto vp = DefaultHex();
  const auto world = Setup("truth", false, 1.0).world;
  hexsim::sim::EnsureOdeInitialised();
  const hexsim::sim::RigidBodyParams bp = hexsim::sim::BodyParamsFor(vp, world, 0.0);
  hexsim::sim::BodyState start;
  start.p_N_m = Eigen::Vector3d(0, 0, -10);
  start.v_N_mps = Eigen::Vector3d(5, 0, 0);
  hexsim::sim::RigidBodyWorld body(bp, start, /*ground=*/true);
  const Eigen::Vector3d hover_B_N(0.0, 0.0, -bp.mass_kg * bp.gravity_mps2);
  const auto steps = static_cast<int64_t>(kInAirSeconds / kPhysicsDt_s);
  for (auto _ : state) {
    for (int64_t i = 0; i < steps; ++i) {
      body.AddForce_B(hover_B_N);
      body.Step(kPhysicsDt_s);
      benchmark::DoNotOptimize(body.State());
    }
    state.PauseTiming();
    body.SetState(start);
    state.ResumeTiming();
  }
  state.SetLabel("default_hex body, ground plane, no contact");
  state.counters["realtime_x"] =
      benchmark::Counter(kInAirSeconds * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["steps"] = static_cast<double>(steps);
}
BENCHMARK(BM_BareOdeInAir)->Unit(benchmark::kMillisecond)->UseRealTime();

// One 1 kHz physics step of a hovering vehicle: powertrain, rotor wrench, ODE step (with the
// ground plane's collision test, body in the air: no contacts).
void BM_PhysicsStep(benchmark::State& state) {
  const auto vp = DefaultHex();
  hexsim::sim::EnsureOdeInitialised();
  hexsim::sim::RigidBodyParams bp;
  bp.mass_kg = vp.mass_kg;
  bp.inertia_kgm2 = vp.inertia_kgm2;
  hexsim::sim::BodyState start;
  start.p_N_m = Eigen::Vector3d(0, 0, -10);
  const bool ground = state.range(0) == 1;
  hexsim::sim::RigidBodyWorld body(bp, start, ground);
  const hexsim::vehicle::RotorWrenchTable rotor_wrench(vp);
  auto pt = hexsim::vehicle::InitialPowertrainState(vp);
  hexsim::vehicle::PowertrainOutput power;
  const std::vector<double> commands(vp.rotors.size(), 0.55);
  for (auto _ : state) {
    const auto s = body.State();
    hexsim::vehicle::StepPowertrain(vp, commands, kPhysicsDt_s, &pt, &power);
    const auto w = rotor_wrench(pt.omega_radps, s.w_B_radps);
    body.AddForce_B(w.force_B_N);
    body.AddTorque_B(w.torque_B_Nm);
    body.Step(kPhysicsDt_s);
    benchmark::DoNotOptimize(power.battery_A);
    if (body.State().p_N_m.norm() > 1e4) body.SetState(start);  // keep it in range on long runs
  }
  state.SetLabel(ground ? "with ground plane" : "free body");
}
BENCHMARK(BM_PhysicsStep)->Arg(0)->Arg(1);

// Console output as usual, and the wall time per physics step of every case kept for the ratios.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& r : runs) {
      const auto steps = r.counters.find("steps");
      if (r.error_occurred || steps == r.counters.end() || steps->second.value <= 0) continue;
      // Single runs, or the median of repetitions (also with --benchmark_report_aggregates_only).
      const bool single = r.run_type == Run::RT_Iteration && r.repetitions <= 1;
      const bool median = r.run_type == Run::RT_Aggregate && r.aggregate_name == "median";
      if (!single && !median) continue;
      const double unit = benchmark::GetTimeUnitMultiplier(r.time_unit);
      const std::string key = r.run_name.function_name + "/" + r.run_name.args;
      per_step_s_[key] = r.GetAdjustedRealTime() / unit / steps->second.value;
      cpu_per_step_s_[key] = r.GetAdjustedCPUTime() / unit / steps->second.value;
      labels_[key] = r.report_label;
    }
    ConsoleReporter::ReportRuns(runs);
  }
  void PrintRatios() const {
    const auto bare = per_step_s_.find("BM_BareOdeInAir/");
    if (bare == per_step_s_.end()) return;
    const double bare_cpu = cpu_per_step_s_.at("BM_BareOdeInAir/");
    std::printf("\nspeed as a fraction of bare ODE in the air (%.3f us per step wall, %.3f CPU), same process run:\n",
                bare->second * 1e6, bare_cpu * 1e6);
    for (const auto& [name, per_step] : per_step_s_) {
      if (name.rfind("BM_FullStack", 0) != 0) continue;
      const double cpu = cpu_per_step_s_.at(name);
      std::printf("  %-32s %-22s %.3f us per step  ratio %.2f (wall)  %.3f us CPU  ratio %.2f (CPU)\n", name.c_str(),
                  labels_.at(name).c_str(), per_step * 1e6, bare->second / per_step, cpu * 1e6, bare_cpu / cpu);
    }
  }

 private:
  std::map<std::string, double> per_step_s_;  // wall time per physics step
  std::map<std::string, double> cpu_per_step_s_;
  std::map<std::string, std::string> labels_;
};

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  reporter.PrintRatios();
  benchmark::Shutdown();
  return 0;
}
