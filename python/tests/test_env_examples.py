"""python/examples: the motors-mode PD hovers and the CEM tuner improves its gains, run as a user runs them."""
import os
import subprocess
import sys

import pytest

EXAMPLES = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "examples")


def run(name, *args):
    return subprocess.run([sys.executable, os.path.join(EXAMPLES, name), *map(str, args)], capture_output=True,
                          text=True, check=False, timeout=300)


@pytest.mark.parametrize("vehicle", ["default_hex", "quad_x"])
def test_given_the_motors_pd_then_the_vehicle_holds_its_hover_point(vehicle):
    done = run("motors_pd_hover.py", "--seconds", 4, "--vehicle", vehicle)
    assert done.returncode == 0, done.stdout + done.stderr
    error_m = float(done.stdout.split("position error ")[1].split(" m")[0])
    assert error_m < 0.3


def test_given_cem_over_a_vector_env_then_the_tuned_gains_beat_the_start_on_held_out_seeds():
    done = run("cem_tune.py", "--generations", 3, "--population", 12)
    assert done.returncode == 0, done.stdout + done.stderr
    line = done.stdout.split("held-out mean return: ")[1]
    before = float(line.split(") ")[1].split(";")[0])
    after = float(line.split(") ")[2].split(";")[0])
    assert after > before + 20.0  # the start gains are sluggish: the tuned ones gain a clear margin
