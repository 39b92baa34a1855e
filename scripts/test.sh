#!/usr/bin/env bash
# Sets up, builds and runs every test (the README's second command).
# chromium: the browser test opens the HTML reports headless (test/browser_test.cc; skipped without it).
# pytest runs python/tests as the CTest tests python_* (python/CMakeLists.txt).
set -euo pipefail
cd "$(dirname "$0")/.."
# python3-dev pybind11-dev python3-numpy: the Python module (python/); python3-pytest runs its tests
# under CTest; matplotlib, venv, wheel, setuptools: the examples and `pip install .` (README "Python").
PYTHON_PACKAGES="python3 python3-dev pybind11-dev python3-numpy python3-pytest python3-matplotlib python3-venv python3-wheel python3-setuptools"
# nodejs npm: the PX4 bridge's independent peer (bridge/test/peer; npm ci fetches node-mavlink under build/).
HEXSIM_EXTRA_PACKAGES="slurm-wlm munge chromium nodejs npm $PYTHON_PACKAGES ${HEXSIM_EXTRA_PACKAGES:-}" scripts/setup.sh build
ctest --test-dir build -j"$(nproc)" --output-on-failure --timeout 600
