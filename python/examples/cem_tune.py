#!/usr/bin/env python3
"""Tune the motors-mode PD's position and velocity gains (kp 1/s², kd 1/s) with the cross-entropy
method over one VectorEnv: each generation, every env flies one candidate from the same start (one
seed for the whole population, a new one per generation), and the best quarter sets the next mean.

    python3 cem_tune.py [--generations 8] [--population 24] [--threads 2]

Prints the mean return of the start gains and of the tuned gains on held-out seeds, and exits 1 when
tuning did not improve it.
"""
import argparse
import os
import sys
import time

import numpy as np

import hexsim

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from motors_pd_hover import pd_motors  # noqa: E402

EPISODE = dict(act="motors", settle_s=3.0, target_N_m=(0.0, 0.0, -2.0), start_offset_m=1.0, time_limit_s=3.0)


def returns(vec, gains, seeds):
    """The return of each row of gains (n, 2), env i flying gains[i] from seeds[i]."""
    obs, _ = vec.reset(seed=list(seeds))
    total, done = np.zeros(vec.num_envs), np.zeros(vec.num_envs, dtype=bool)
    while not done.all():
        obs, reward, terminated, truncated, _ = vec.step(pd_motors(obs, vec, gains[:, 0], gains[:, 1]))
        total += np.where(done, 0.0, reward)
        done |= terminated | truncated  # an env that ended auto-resets on the next step: not counted
    return total


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--generations", type=int, default=8)
    ap.add_argument("--population", type=int, default=24)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    t0 = time.perf_counter()
    vec = hexsim.VectorEnv(args.population, threads=args.threads, **EPISODE)
    rng = np.random.default_rng(args.seed)
    start = np.array([0.3, 0.3])  # a sluggish, underdamped start
    mean, std = start.copy(), np.array([1.0, 1.0])
    n_elite = max(2, args.population // 4)
    for g in range(args.generations):
        gains = np.clip(mean + std * rng.standard_normal((args.population, 2)), 0.05, 6.0)
        r = returns(vec, gains, [1000 + g] * args.population)
        elite = gains[np.argsort(r)[-n_elite:]]
        mean, std = elite.mean(axis=0), elite.std(axis=0) + 0.05
        print(f"generation {g}: best return {r.max():8.1f}, mean gains kp {mean[0]:.2f} kd {mean[1]:.2f}")
    held_out = list(range(5000, 5000 + args.population))  # each env its own start, none seen in tuning
    before = returns(vec, np.tile(start, (args.population, 1)), held_out).mean()
    after = returns(vec, np.tile(mean, (args.population, 1)), held_out).mean()
    print(f"held-out mean return: start gains (kp {start[0]:.2f}, kd {start[1]:.2f}) {before:.1f}; "
          f"tuned (kp {mean[0]:.2f}, kd {mean[1]:.2f}) {after:.1f}; {time.perf_counter() - t0:.1f} s wall")
    return 0 if after > before else 1


if __name__ == "__main__":
    sys.exit(main())
