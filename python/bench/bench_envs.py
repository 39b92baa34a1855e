#!/usr/bin/env python3
"""Environment stepping speed, side by side in one run (issue targets in brackets):

  A  one HoverEnv stepped from Python                     agent steps/s
  B  VectorEnv(64) on 2 threads                           agent steps/s      [B/A >= 3.5]
  C  VectorEnv(64) on 1 thread, per vector step           ms
  D  the same 64 simulations in a plain C++ loop          ms                 [C/D <= 1.10]
  E  reference: hexsim.Simulation stepped from Python with the episode's observation and reward
     computed in Python (what HoverEnv did before its episode logic moved to C++)   steps/s

One agent step = control_period_s (10 ms) = 10 physics steps, attitude mode holding level at the
hover collective (the same constant action everywhere: no Python controller cost on either side);
an episode that ends is reset (A by hand, B and C by auto-reset) inside the timed window.
Each figure is the best of --repeats windows. Wall time is the target's measure; CPU time (this
process, all threads) is printed beside it because a shared machine's load inflates wall time: on a
machine whose other processes take the cores, B's wall figure understates the vector, and C/D is
read from CPU time, which other processes do not change.
Usage: bench_envs.py [--steps N] [--repeats R] [--n 64] [--json FILE]
"""
import argparse
import json
import os
import time

import numpy as np

import hexsim

LONG = dict(time_limit_s=100.0, act="attitude")


def measure(repeats, fn):
    """Best (wall, cpu) seconds of `repeats` calls of fn."""
    best = (float("inf"), float("inf"))
    for _ in range(repeats):
        w0, c0 = time.perf_counter(), time.process_time()
        fn()
        w, c = time.perf_counter() - w0, time.process_time() - c0
        best = (min(best[0], w), min(best[1], c))
    return best


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=200, help="vector steps per timed window (A: n/4 times more)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--json", help="also write the figures here")
    args = ap.parse_args()

    env = hexsim.HoverEnv(**LONG)
    env.reset(seed=1)
    level = np.array([0.0, 0.0, 0.0, env.hover_thrust_N / env.max_thrust_N])
    single_steps = max(1, args.n // 4) * args.steps

    def fly_single():
        for _ in range(single_steps):
            _, _, terminated, truncated, _ = env.step(level)
            if terminated or truncated:
                env.reset()
    wall_a, cpu_a = (t / single_steps for t in measure(args.repeats, fly_single))

    actions = np.tile(level, (args.n, 1))

    def fly(vec):
        return lambda: [vec.step(actions) for _ in range(args.steps)]

    vec2 = hexsim.VectorEnv(args.n, threads=2, **LONG)
    vec2.reset(seed=1)
    wall_b, cpu_b = (t / (args.steps * args.n) for t in measure(args.repeats, fly(vec2)))

    vec1 = hexsim.VectorEnv(args.n, threads=1, **LONG)
    vec1.reset(seed=1)
    c, d = [], []
    for _ in range(args.repeats):  # interleaved, so that both see the same machine load
        c.append(measure(1, fly(vec1)))
        d.append(measure(1, lambda: vec1.bench_physics(args.steps)))
    wall_c, cpu_c = (min(x[k] for x in c) / args.steps for k in (0, 1))
    wall_d, cpu_d = (min(x[k] for x in d) / args.steps for k in (0, 1))

    sim = hexsim.Simulation(estimator="truth", duration=1000.0)
    sim.act("position", [0.0, 0.0, -5.0])
    sim.step(6000)
    target = np.array([0.0, 0.0, -5.0])

    def fly_python_episode_logic():
        for _ in range(single_steps):
            sim.act("attitude", [1.0, 0.0, 0.0, 0.0, env.hover_thrust_N])
            sim.step(10)
            x = sim.state_vector()
            obs = np.concatenate([target - x[1:4], x[4:7], x[7:11], x[11:14], sim.sensors()["mag_uT"]])
            error, rates = obs[0:3], obs[10:13]
            _ = -(float(error @ error) + 0.1 * float(rates @ rates))
    wall_e, cpu_e = (t / single_steps for t in measure(args.repeats, fly_python_episode_logic))

    load = os.getloadavg()[0]
    figures = {
        "single_env_steps_per_s": 1.0 / wall_a, "vector_2_threads_steps_per_s": 1.0 / wall_b,
        "vector_over_single_wall": wall_a / wall_b, "vector_over_single_cpu": cpu_a / cpu_b,
        "vector_1_thread_step_s": wall_c, "cpp_loop_step_s": wall_d,
        "vector_over_cpp_loop_wall": wall_c / wall_d, "vector_over_cpp_loop_cpu": cpu_c / cpu_d,
        "python_episode_logic_steps_per_s": 1.0 / wall_e, "vector_over_python_episode_logic_wall": wall_e / wall_b,
        "n": args.n, "steps": args.steps, "repeats": args.repeats, "load_average_1min": load,
        "version": hexsim.__version__,
    }
    print(f"load average {load:.1f} on {os.cpu_count()} cores")
    print(f"A  HoverEnv from Python        {1 / wall_a:9.0f} steps/s wall  ({wall_a * 1e6:6.1f} µs/step; cpu {cpu_a * 1e6:6.1f})")
    print(f"B  VectorEnv({args.n}), 2 threads   {1 / wall_b:9.0f} steps/s wall  ({wall_b * 1e6:6.1f} µs/env-step; cpu {cpu_b * 1e6:6.1f})")
    print(f"   B/A wall {wall_a / wall_b:.2f} (target >= 3.5: {'met' if wall_a / wall_b >= 3.5 else 'MISSED'}); "
          f"cpu per step A/B {cpu_a / cpu_b:.2f} (x2 with two free cores: {2 * cpu_a / cpu_b:.2f})")
    print(f"C  VectorEnv({args.n}), 1 thread    {wall_c * 1e3:7.3f} ms/vector step wall (cpu {cpu_c * 1e3:.3f})")
    print(f"D  same sims, C++ loop         {wall_d * 1e3:7.3f} ms/vector step wall (cpu {cpu_d * 1e3:.3f})")
    print(f"   C/D wall {wall_c / wall_d:.3f}, cpu {cpu_c / cpu_d:.3f} (target <= 1.10: "
          f"{'met' if cpu_c / cpu_d <= 1.10 else 'MISSED'} by cpu)")
    print(f"E  Simulation + Python logic   {1 / wall_e:9.0f} steps/s wall  ({wall_e * 1e6:6.1f} µs/step; cpu {cpu_e * 1e6:6.1f});"
          f" B/E wall {wall_e / wall_b:.2f}, cpu x2 {2 * cpu_e / cpu_b:.2f}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(figures, f, indent=2)


if __name__ == "__main__":
    main()
