#!/usr/bin/env python3
"""Speed of hexsim from Python, beside the C++ figure measured in the same run (issue 22 item 6).

  cpp          bench_sim's BM_FullStack/0/1: the square's first 20 s from the ground, built-in
               cascade on the true state, 100 Hz log, in C++ (Google Benchmark, its CPU time)
  chunks       the same run from Python: Simulation(...).step(n=1000) until the 20 s are flown (the
               YAML reading in Simulation(...) untimed, as bench_sim loads its setup once)
  pd_1khz      a PD controller written in Python (examples/python/pd_hover.py) called at every 1 ms
               step: state_vector() -> PD -> act("attitude") -> step(); take-off and hover, 20 s
Each figure is real-time factor = simulated s / CPU s of this process (or of bench_sim), median of
--repeat runs; the machine is shared, so only the ratio chunks / cpp taken side by side means much.

    PYTHONPATH=build/python python3 bench/python_speed.py [--bench-sim build/bench/bench_sim] [--repeat 5]
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "examples", "python"))

import hexsim  # noqa: E402
import pd_hover  # noqa: E402

SIM_S = 20.0


def cpu_timed(make, fly):
    """CPU seconds of fly(make()): the stepping only, as bench_sim times RunMission on a loaded setup
    (Simulation::Create is inside both; reading the YAML files is outside both)."""
    sim = make()
    t0 = time.process_time()
    fly(sim)
    return time.process_time() - t0


def make_square():
    return hexsim.Simulation(mission="square", estimator="truth", duration=SIM_S)


def chunks(sim):
    while sim.step(1000):
        pass
    assert abs(sim.time_s - SIM_S) < 0.01, sim.time_s


def make_hover():
    return hexsim.Simulation(mission="square", estimator="truth", duration=SIM_S + 1.0)


def pd_1khz(sim):
    pd = pd_hover.PDController(sim.hover_thrust_N / pd_hover.G_MPS2)
    target = (0.0, 0.0, -5.0)
    act, step, state_vector = sim.act, sim.step, sim.state_vector
    x = state_vector().tolist()
    while x[0] < SIM_S:
        act("attitude", pd(x, target))
        step()
        x = state_vector().tolist()


def cpp(bench_sim, repeat):
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "bench.json")
        subprocess.run([bench_sim, "--benchmark_filter=^BM_FullStack/0/1/", f"--benchmark_repetitions={repeat}",
                        f"--benchmark_out={out}", "--benchmark_out_format=json"], capture_output=True, check=True)
        runs = [b for b in json.load(open(out))["benchmarks"] if b.get("run_type") == "iteration"]
    # cpu_time is per iteration, in the benchmark's time unit (ms).
    return statistics.median(SIM_S / (b["cpu_time"] / 1000.0) for b in runs)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bench-sim", default=os.path.join(ROOT, "build", "bench", "bench_sim"))
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    chunks(make_square())  # warm-up: page faults, caches
    x_chunks = statistics.median(SIM_S / cpu_timed(make_square, chunks) for _ in range(args.repeat))
    x_pd = statistics.median(SIM_S / cpu_timed(make_hover, pd_1khz) for _ in range(args.repeat))
    x_cpp = cpp(args.bench_sim, args.repeat) if os.access(args.bench_sim, os.X_OK) else float("nan")
    load = open("/proc/loadavg").read().split()[0]
    print(f"python_speed: load average {load}, {os.cpu_count()} cores, median of {args.repeat}, CPU time")
    print(f"  C++ BM_FullStack/0/1 (square 20 s, truth, log)   {x_cpp:8.0f} x real time")
    print(f"  Python step(n=1000), same run                    {x_chunks:8.0f} x real time  "
          f"({100 * x_chunks / x_cpp:.0f} % of C++; goal >= 90 %)")
    print(f"  Python PD callback at 1 kHz (hover, 20 s)        {x_pd:8.0f} x real time  (goal >= 100 x)")


if __name__ == "__main__":
    main()
