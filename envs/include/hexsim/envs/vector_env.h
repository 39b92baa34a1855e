// n environments stepped in one call on a pool of threads. Each env is independent and its episodes
// depend only on its own seed, so the results do not depend on n, the thread count or which thread
// steps which env.
//
// Auto-reset (Gymnasium's "next step" mode): the step after an env's episode ended starts its next
// episode instead (the action is ignored; reward 0, neither terminated nor truncated; the new
// episode's first observation). Without auto-reset that step is bad input.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "hexsim/common/status.h"
#include "hexsim/envs/env.h"

namespace hexsim::envs {

// Runs fn(i) for i in [0, n) on `threads` threads (the caller's included). Each thread allocates
// ODE's per-thread data before it steps a world.
class ThreadPool {
 public:
  explicit ThreadPool(int threads);
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;
  int threads() const { return static_cast<int>(workers_.size()) + 1; }
  void ParallelFor(size_t n, const std::function<void(size_t)>& fn);

 private:
  void Work();
  void Drain();

  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable start_, done_;
  const std::function<void(size_t)>* fn_ = nullptr;
  size_t n_ = 0;
  size_t next_ = 0;      // next index to hand out (under mutex_)
  size_t running_ = 0;   // workers still inside the current job
  uint64_t generation_ = 0;
  bool stop_ = false;
};

class VectorEnv {
 public:
  // Every env must have the same observation and action sizes. threads >= 1.
  VectorEnv(std::vector<std::unique_ptr<Env>> envs, int threads, bool autoreset);

  size_t size() const { return envs_.size(); }
  size_t observation_size() const { return envs_.front()->observation_size(); }
  size_t action_size() const { return envs_.front()->action_size(); }
  int threads() const { return pool_.threads(); }
  const Env& env(size_t i) const { return *envs_[i]; }

  // seeds: one per env (a new episode stream each), or nullptr (each env's next episode).
  // obs: n × observation_size(); info: n × kInfoSize. On failure the first failing env's status.
  Status Reset(const uint64_t* seeds, double* obs, double* info);
  // Resets env i alone (seed or, when null, its next episode).
  Status ResetOne(size_t i, const uint64_t* seed, double* obs, double* info);
  // actions: n × action_size(). Writes obs (n × observation_size()), rewards, terminated and truncated
  // (n each, 0/1), info (n × kInfoSize).
  Status Step(const double* actions, double* obs, double* rewards, uint8_t* terminated, uint8_t* truncated,
              double* info);
  // Benchmark reference: the same simulations advanced agent_steps × steps_per_action physics steps
  // in a plain loop on the calling thread, holding their current actions; no observation, reward or
  // episode logic. Episodes may run past their time limit.
  void StepPhysicsOnly(int agent_steps);

 private:
  std::vector<std::unique_ptr<Env>> envs_;
  ThreadPool pool_;
  bool autoreset_ = true;
  std::vector<Status> status_;  // per env, from the last call
};

}  // namespace hexsim::envs
