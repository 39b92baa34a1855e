#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "hexsim/common/rotation.h"
#include "hexsim/envs/env.h"
#include "hexsim/envs/vector_env.h"
#include "hexsim/sim/run_config.h"

namespace hexsim::envs {
namespace {

sim::RunSetup LoadSetup(const std::string& estimator = "truth") {
  sim::RunRequest rq;
  rq.estimator = estimator;
  return sim::LoadRunSetup(rq).value();
}

EnvOptions ShortHover(ActMode act = ActMode::kMotors) {
  EnvOptions o;
  o.act = act;
  o.settle_s = 3.0;  // the take-off to 2 m settles within 3 s
  o.target_N_m = Eigen::Vector3d(0.0, 0.0, -2.0);
  o.time_limit_s = 0.1;
  return o;
}

std::unique_ptr<Env> Make(const EnvOptions& o, const std::string& estimator = "truth") {
  return Env::Create(LoadSetup(estimator), o).value();
}

struct Trace {
  std::vector<double> obs, rewards;
};

// Steps `env` for `steps` agent steps holding the hover command, resetting (next episode) when an
// episode ends, and records every observation and reward.
Trace Fly(Env* env, uint64_t seed, int steps) {
  Trace t;
  std::vector<double> obs(env->observation_size());
  const std::vector<double> action(env->action_size(), env->layout().hover_command);
  EXPECT_TRUE(env->Reset(seed, obs.data()).ok());
  t.obs.insert(t.obs.end(), obs.begin(), obs.end());
  for (int k = 0; k < steps; ++k) {
    if (env->episode_over()) {
      EXPECT_TRUE(env->Reset(obs.data()).ok());
      t.rewards.push_back(0.0);
    } else {
      t.rewards.push_back(env->Step(action.data(), obs.data()).reward);
    }
    t.obs.insert(t.obs.end(), obs.begin(), obs.end());
  }
  return t;
}

TEST(EnvTest, GivenOneSeedWhenFlownTwiceThenTheEpisodesAreIdenticalAndAnotherSeedDiffers) {
  auto a = Make(ShortHover()), b = Make(ShortHover()), c = Make(ShortHover());
  const Trace ta = Fly(a.get(), 7, 25), tb = Fly(b.get(), 7, 25), tc = Fly(c.get(), 8, 25);
  EXPECT_EQ(ta.obs, tb.obs);
  EXPECT_EQ(ta.rewards, tb.rewards);
  EXPECT_NE(ta.obs, tc.obs);
  EXPECT_NE(a->episode_sim_seed(), c->episode_sim_seed());
}

TEST(EnvTest, GivenAVectorOnTwoThreadsThenEachEnvMatchesTheSameEnvSteppedAlone) {
  const int n = 5, steps = 25;  // 0.1 s episodes: every env auto-resets twice
  std::vector<std::unique_ptr<Env>> envs(n);
  for (auto& e : envs) e = Make(ShortHover());
  VectorEnv vec(std::move(envs), 2, true);
  const size_t no = vec.observation_size(), na = vec.action_size();
  std::vector<double> obs(n * no), info(n * kInfoSize), rewards(n);
  std::vector<uint8_t> term(n), trunc(n);
  std::vector<uint64_t> seeds(n);
  for (int i = 0; i < n; ++i) seeds[i] = 100 + i;
  ASSERT_TRUE(vec.Reset(seeds.data(), obs.data(), info.data()).ok());
  std::vector<Trace> got(n);
  for (int i = 0; i < n; ++i) got[i].obs.assign(obs.begin() + i * no, obs.begin() + (i + 1) * no);
  const std::vector<double> actions(n * na, vec.env(0).layout().hover_command);
  for (int k = 0; k < steps; ++k) {
    ASSERT_TRUE(vec.Step(actions.data(), obs.data(), rewards.data(), term.data(), trunc.data(), info.data()).ok());
    for (int i = 0; i < n; ++i) {
      got[i].obs.insert(got[i].obs.end(), obs.begin() + i * no, obs.begin() + (i + 1) * no);
      got[i].rewards.push_back(rewards[i]);
    }
  }
  for (int i = 0; i < n; ++i) {
    auto alone = Make(ShortHover());
    const Trace want = Fly(alone.get(), 100 + i, steps);
    EXPECT_EQ(got[i].obs, want.obs) << "env " << i;
    EXPECT_EQ(got[i].rewards, want.rewards) << "env " << i;
  }
}

TEST(EnvTest, GivenTheLayoutsHoverCommandWhenHeldInMotorsModeThenTheVehicleNeitherFallsNorClimbs) {
  EnvOptions o = ShortHover();
  o.time_limit_s = 1.0;
  auto env = Make(o);
  const VehicleLayout& layout = env->layout();
  ASSERT_EQ(layout.mixer.rows(), 4);
  ASSERT_EQ(static_cast<size_t>(layout.mixer.cols()), layout.rotors);
  EXPECT_GT(layout.hover_command, 0.05);
  EXPECT_LT(layout.hover_command, 0.95);
  // Equal rotor thrusts m·g/N: the mixer gives the collective m·g and (a symmetric frame) no torque.
  const Eigen::VectorXd t = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(layout.rotors),
                                                      layout.hover_thrust_N / static_cast<double>(layout.rotors));
  const Eigen::VectorXd wrench = layout.mixer * t;
  EXPECT_NEAR(wrench[0], layout.hover_thrust_N, 1e-9 * layout.hover_thrust_N);
  EXPECT_LT(wrench.tail<3>().norm(), 1e-9);
  // Free fall for 0.5 s would reach 4.9 m/s; the hover command holds the vertical speed within 0.5 m/s
  // (the battery sags below full charge and the settle leaves a little speed), 20 % more climbs.
  auto fly = [&](double command) {
    std::vector<double> obs(env->observation_size()), a(env->action_size(), command);
    EXPECT_TRUE(env->Reset(3, obs.data()).ok());
    for (int k = 0; k < 50; ++k) {
      const StepOutput out = env->Step(a.data(), obs.data());
      EXPECT_FALSE(out.terminated || out.truncated) << "command " << command << ", step " << k << ", v_D " << obs[5];
      if (out.terminated || out.truncated) break;
    }
    return obs[5];  // v_D (m/s)
  };
  EXPECT_LT(std::abs(fly(layout.hover_command)), 0.5);
  EXPECT_LT(fly(1.2 * layout.hover_command), -0.5);
}

TEST(EnvTest, GivenCompassWaypointThenTheTrueAttitudeIsNeverObservedAndCrossTrackIsTheDistanceFromTheLeg) {
  EnvOptions o;
  o.task = Task::kCompassWaypoint;
  o.observe = ObsSource::kTruth;
  o.waypoints_N_m = {Eigen::Vector3d(20.0, 0.0, -5.0)};
  EXPECT_FALSE(Env::Create(LoadSetup("eskf"), o).ok());  // truth is refused
  o.observe = ObsSource::kSensors;
  o.act = ActMode::kAttitude;
  o.time_limit_s = 4.0;
  o.start_offset_m = 0.0;
  auto env = Make(o, "eskf");
  ASSERT_EQ(env->observation_size(), 20u);
  std::vector<double> obs(env->observation_size()), info(kInfoSize);
  ASSERT_TRUE(env->Reset(1, obs.data()).ok());
  EXPECT_NEAR(obs[17], 1.0, 1e-12);  // the leg (0, 0) → (20, 0) points north
  env->Info(info.data());
  const double north0_m = info[kInfoTrueN];
  // Pitch nose down 5° with the hover thrust, yaw setpoint north: the vehicle flies north.
  const double pitch = -5.0 * kDegToRad / o.max_tilt_rad;
  const std::vector<double> a = {0.0, pitch, 0.0, env->layout().hover_thrust_N / env->layout().max_thrust_N};
  double along_m = north0_m, sum_progress_m = 0.0;
  for (int k = 0; k < 300; ++k) {
    const StepOutput out = env->Step(a.data(), obs.data());
    ASSERT_FALSE(out.terminated || out.truncated) << "step " << k;
    env->Info(info.data());
    // On a leg along north from the origin the cross-track error is |E| and the progress ΔN.
    EXPECT_NEAR(info[kInfoCrossTrackM], std::abs(info[kInfoTrueE]), 1e-12);
    EXPECT_LE(out.reward, info[kInfoTrueN] - along_m + 1e-12);  // the penalties are never positive
    sum_progress_m += info[kInfoTrueN] - along_m;
    along_m = info[kInfoTrueN];
  }
  EXPECT_GT(sum_progress_m, 1.0);  // 3 s at up to g·tan 5° = 0.86 m/s² (3.9 m without drag or the tilt-in)
  EXPECT_LT(std::abs(info[kInfoYawErrorDeg]), 30.0);
}

TEST(EnvTest, GivenNoAutoResetWhenSteppingAFinishedEpisodeThenItIsBadInput) {
  std::vector<std::unique_ptr<Env>> envs;
  envs.push_back(Make(ShortHover()));
  VectorEnv vec(std::move(envs), 1, false);
  std::vector<double> obs(vec.observation_size()), info(kInfoSize), r(1);
  std::vector<uint8_t> te(1), tr(1);
  const std::vector<double> a(vec.action_size(), vec.env(0).layout().hover_command);
  const uint64_t seed = 1;
  ASSERT_TRUE(vec.Reset(&seed, obs.data(), info.data()).ok());
  for (int k = 0; k < 10; ++k) ASSERT_TRUE(vec.Step(a.data(), obs.data(), r.data(), te.data(), tr.data(), info.data()).ok());
  EXPECT_EQ(tr[0], 1);  // 0.1 s = 10 agent steps
  const Status s = vec.Step(a.data(), obs.data(), r.data(), te.data(), tr.data(), info.data());
  EXPECT_EQ(s.code(), StatusCode::kBadInput);
}

TEST(EnvTest, GivenBadOptionsThenCreateNamesTheField) {
  EnvOptions o;
  o.control_period_s = 0.0;
  const auto r = Env::Create(LoadSetup(), o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("control_period_s"), std::string::npos);
  o = EnvOptions{};
  o.task = Task::kWaypoint;
  EXPECT_NE(Env::Create(LoadSetup(), o).status().message().find("waypoints_N_m"), std::string::npos);
}

}  // namespace
}  // namespace hexsim::envs
