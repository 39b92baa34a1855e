#include "hexsim/envs/vector_env.h"

#include <algorithm>
#include <string>

#include "hexsim/sim/rigid_body.h"

namespace hexsim::envs {

ThreadPool::ThreadPool(int threads) {
  for (int t = 1; t < std::max(1, threads); ++t) workers_.emplace_back([this] { Work(); });
}

ThreadPool::~ThreadPool() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  start_.notify_all();
  for (auto& w : workers_) w.join();
}

// Hands out indices one by one: a long reset on one env does not hold up a fixed block of others.
void ThreadPool::Drain() {
  for (;;) {
    size_t i = 0;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (next_ >= n_) return;
      i = next_++;
    }
    (*fn_)(i);
  }
}

void ThreadPool::Work() {
  sim::EnsureOdeInitialised();  // this thread steps ODE worlds: its per-thread data first
  uint64_t seen = 0;
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      start_.wait(lock, [&] { return stop_ || generation_ != seen; });
      if (stop_) return;
      seen = generation_;
    }
    Drain();
    std::lock_guard<std::mutex> lock(mutex_);
    if (--running_ == 0) done_.notify_one();
  }
}

void ThreadPool::ParallelFor(size_t n, const std::function<void(size_t)>& fn) {
  sim::EnsureOdeInitialised();  // the calling thread steps worlds too
  if (workers_.empty() || n <= 1) {
    for (size_t i = 0; i < n; ++i) fn(i);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    fn_ = &fn;
    n_ = n;
    next_ = 0;
    running_ = workers_.size();
    ++generation_;
  }
  start_.notify_all();
  Drain();
  std::unique_lock<std::mutex> lock(mutex_);
  done_.wait(lock, [&] { return running_ == 0; });
  fn_ = nullptr;
}

VectorEnv::VectorEnv(std::vector<std::unique_ptr<Env>> envs, int threads, bool autoreset)
    : envs_(std::move(envs)), pool_(threads), autoreset_(autoreset), status_(envs_.size()) {
  HEXSIM_CHECK(!envs_.empty());
  for (const auto& e : envs_) {
    HEXSIM_CHECK(e->observation_size() == observation_size() && e->action_size() == action_size());
  }
}

namespace {
// The first failure in env order (the same whichever thread finished first), naming the env.
Status FirstFailure(const std::vector<Status>& status) {
  for (size_t i = 0; i < status.size(); ++i) {
    if (!status[i].ok()) {
      return status[i].WithContext("env " + std::to_string(i));
    }
  }
  return Status::Ok();
}
}  // namespace

Status VectorEnv::ResetOne(size_t i, const uint64_t* seed, double* obs, double* info) {
  Env& e = *envs_[i];
  Status s = seed ? e.Reset(*seed, obs) : e.Reset(obs);
  if (s.ok()) e.Info(info);
  return s;
}

Status VectorEnv::Reset(const uint64_t* seeds, double* obs, double* info) {
  const size_t no = observation_size();
  pool_.ParallelFor(size(), [&](size_t i) {
    status_[i] = ResetOne(i, seeds ? seeds + i : nullptr, obs + i * no, info + i * kInfoSize);
  });
  return FirstFailure(status_);
}

Status VectorEnv::Step(const double* actions, double* obs, double* rewards, uint8_t* terminated,
                       uint8_t* truncated, double* info) {
  const size_t no = observation_size(), na = action_size();
  pool_.ParallelFor(size(), [&](size_t i) {
    Env& e = *envs_[i];
    double* o = obs + i * no;
    rewards[i] = 0.0;
    terminated[i] = truncated[i] = 0;
    if (e.episode_over() && e.simulation() != nullptr && autoreset_) {
      status_[i] = ResetOne(i, nullptr, o, info + i * kInfoSize);
      return;
    }
    if (e.episode_over()) {
      status_[i] = Status::BadInput("step: the episode is over (call reset() first)");
      return;
    }
    const StepOutput out = e.Step(actions + i * na, o);
    rewards[i] = out.reward;
    terminated[i] = out.terminated ? 1 : 0;
    truncated[i] = out.truncated ? 1 : 0;
    e.Info(info + i * kInfoSize);
    status_[i] = Status::Ok();
  });
  return FirstFailure(status_);
}

void VectorEnv::StepPhysicsOnly(int agent_steps) {
  sim::EnsureOdeInitialised();
  for (int k = 0; k < agent_steps; ++k) {
    for (auto& e : envs_) {
      sim::Simulation* s = e->simulation();
      if (s == nullptr) continue;
      for (int j = 0; j < e->steps_per_action(); ++j) s->Step();
    }
  }
}

}  // namespace hexsim::envs
