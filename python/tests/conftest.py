"""Shared fixtures: the hexsim CLI built beside the module (HEXSIM_CLI, set by CTest), and the
examples directory (the tests fly the example PD controller)."""
import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "examples", "python"))


@pytest.fixture(scope="session")
def cli():
    """Runs `hexsim ARGS...`; returns the CompletedProcess (text)."""
    exe = os.environ.get("HEXSIM_CLI") or os.path.join(ROOT, "build", "apps", "hexsim")
    if not os.access(exe, os.X_OK):
        pytest.skip(f"no hexsim CLI at {exe} (set HEXSIM_CLI)")

    def run(*args):
        return subprocess.run([exe, *map(str, args)], capture_output=True, text=True, check=False)
    return run
