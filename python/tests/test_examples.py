"""examples/python: each runs as a user would run it and does what it says."""
import os
import subprocess
import sys

import pytest

from conftest import ROOT

EXAMPLES = os.path.join(ROOT, "examples", "python")


def run_example(name, *args):
    env = dict(os.environ, MPLBACKEND="Agg")
    return subprocess.run([sys.executable, os.path.join(EXAMPLES, name), *map(str, args)], capture_output=True,
                          text=True, check=False, env=env, timeout=120)


def test_given_no_file_when_calibrating_the_synthetic_array_then_the_known_offset_is_printed_back():
    done = run_example("calibrate_array.py")
    assert done.returncode == 0, done.stderr
    assert "method: ellipsoid" in done.stdout and "fit accepted" in done.stdout
    offset = done.stdout.split("offset_uT: [")[1].split("]")[0].split()
    assert [round(float(v)) for v in offset] == [18, -9, 25]


def test_given_the_python_pd_when_flying_the_square_then_it_returns_home_and_plots(tmp_path):
    pytest.importorskip("matplotlib")
    import hexsim
    import pd_hover
    sim = pd_hover.fly_square(hexsim)
    x = sim.state_vector()
    assert abs(x[1]) < 1.0 and abs(x[2]) < 1.0 and abs(x[3] + 10.0) < 0.3   # back over home at 10 m
    log = sim.log()
    assert log["pos_N_m"].max() > 39.0 and log["pos_E_m"].max() > 39.0   # the far corner was flown
    done = run_example("pd_hover.py", "--out", tmp_path / "square.png")
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "square.png").stat().st_size > 10000
