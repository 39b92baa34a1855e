// The steppable Simulation: same bytes as RunMission, plug-in controller, hooks and disturbances.
#include <cmath>
#include <memory>

#include <gtest/gtest.h>

#include "hexsim/control/controller.h"
#include "hexsim/sim/run_config.h"
#include "hexsim/sim/simulation.h"

namespace hexsim::sim {
namespace {

RunSetup MakeSetup(const std::string& estimator) {
  RunRequest req;
  req.mission = "square";
  req.vehicle = "default_hex";
  req.estimator = estimator;
  req.seed = 11;
  return LoadRunSetup(req).value();
}

TEST(Simulation, GivenASetup_WhenSteppedByHand_ThenTheLogEqualsRunMissionsExactly) {
  RunSetup setup = MakeSetup("complementary");
  setup.options.duration_s = 8.0;
  const RunOutput a = RunMission(setup);
  auto sim = Simulation::Create(setup).value();
  int steps = 0;
  while (sim->Step()) ++steps;
  EXPECT_FALSE(sim->Step());  // spent
  const RunOutput b = sim->Finish();
  EXPECT_EQ(steps, 8001);  // k = 0 … 8000 at 1 kHz: each logs (at the log rate) and steps physics
  ASSERT_EQ(a.log.rows(), b.log.rows());
  ASSERT_EQ(a.log.columns(), b.log.columns());
  const size_t n_cols = a.log.columns().size();
  for (size_t c = 0; c < n_cols; ++c) {
    const auto& ca = a.log.Column(c);
    const auto& cb = b.log.Column(c);
    for (size_t r = 0; r < ca.size(); ++r) {
      if (std::isnan(ca[r])) {
        EXPECT_TRUE(std::isnan(cb[r]));
      } else {
        ASSERT_EQ(ca[r], cb[r]) << "column " << c << " row " << r;
      }
    }
  }
}

// Counts calls and delegates to the cascade: a plug-in flies the mission through the interface.
class CountingController final : public control::Controller {
 public:
  CountingController(const control::ControllerParams& p, const control::VehicleModelForControl& m, int* calls)
      : inner_(p, m), calls_(calls) {}
  control::ControlOutput Update(const control::NavState& s, const control::Setpoint& sp, double dt) override {
    ++*calls_;
    return inner_.Update(s, sp, dt);
  }
  void Reset() override { inner_.Reset(); }

 private:
  control::CascadedController inner_;
  int* calls_;
};

TEST(Simulation, GivenAPluggedInController_WhenTheMissionIsFlown_ThenItIsCalledAtTheImuRateAndCompletes) {
  const RunSetup setup = MakeSetup("truth");
  int calls = 0;
  Plugins plugins;
  plugins.controller = std::make_unique<CountingController>(setup.control, ControlModelFor(setup.vehicle), &calls);
  auto sim = Simulation::Create(setup, std::move(plugins)).value();
  EXPECT_EQ(sim->builtin_controller(), nullptr);
  sim->RunToEnd();
  const RunOutput out = sim->Finish();
  EXPECT_EQ(out.summary.status, RunStatus::kCompleted);
  // Called on every fresh IMU sample while armed: at least 10 s of flight at ≥ 100 Hz.
  EXPECT_GT(calls, 1000);
}

TEST(Simulation, GivenAnExternalForceAndPayload_WhenApplied_ThenTheStateAccessorsShowThem) {
  const RunSetup setup = MakeSetup("truth");
  Plugins plugins;
  plugins.setpoint_hook = [](double, const control::NavState&, control::Setpoint* sp) { sp->idle = true; };
  auto sim = Simulation::Create(setup, std::move(plugins)).value();
  sim->ChangePayload(0.5);
  EXPECT_DOUBLE_EQ(sim->payload_kg(), setup.mission.payload_kg + 0.5);
  sim->ChangePayload(-10.0);
  EXPECT_DOUBLE_EQ(sim->payload_kg(), 0.0);  // never negative
  // Motors idle on the ground: 2 s of a 30 N northward push slides the vehicle north.
  sim->SetExternalForce(Eigen::Vector3d(30.0, 0.0, 0.0));
  for (int i = 0; i < 2000; ++i) ASSERT_TRUE(sim->Step());
  EXPECT_NEAR(sim->time_s(), 2.0, 1e-9);
  EXPECT_GT(sim->true_state().p_N_m.x(), 0.5);
  EXPECT_EQ(sim->control_output().thrust_N, 0.0);
  EXPECT_EQ(sim->currents().motor_A.size(), setup.vehicle.rotors.size());
}


TEST(Simulation, GivenStreamsRequested_WhenRun_ThenTheTableIsByteIdenticalAndImuRcouBattComeAtTheirOwnRate) {
  RunSetup setup = MakeSetup("truth");
  setup.options.duration_s = 3.0;
  setup.options.log_rate_hz = 10.0;
  const RunOutput plain = RunMission(setup);
  setup.options.stream_rate_hz = 50.0;
  const RunOutput streamed = RunMission(setup);
  EXPECT_TRUE(plain.log.stream_names().empty());
  EXPECT_EQ(logs::FlightLogToCsv(plain.log), logs::FlightLogToCsv(streamed.log));
  for (const char* name : {"imu", "rcou", "batt"}) {
    const logs::FlightLog* s = streamed.log.Stream(name);
    ASSERT_NE(s, nullptr) << name;
    EXPECT_NEAR(static_cast<double>(s->rows()), 3.0 * 50.0, 2.0) << name;  // 50 Hz, never resampled to the rows
  }
}

}  // namespace
}  // namespace hexsim::sim
