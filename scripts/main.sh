#!/usr/bin/env bash
# Sets up, builds and runs hexsim's main job on its built-in defaults (the README's first command):
# the paper's hex-rotor flies the climb-and-cruise square with each compass calibration (each learnt
# on the simulated turntable), and the comparison report is written.
set -euo pipefail
cd "$(dirname "$0")/.."
# Only the hexsim command and its libraries: the tests, benchmarks, examples and Python module are
# built by scripts/test.sh (through the same ccache).
scripts/setup.sh build hexsim >&2
OUT=${HEXSIM_OUT:-out/main}
rm -rf "$OUT"
./build/apps/hexsim compare --out "$OUT"
echo "hexsim: report written to $OUT/report.html"
