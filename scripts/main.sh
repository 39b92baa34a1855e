#!/usr/bin/env bash
# Sets up, builds and runs hexsim's main job on its built-in defaults (the README's first command).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh build >&2
OUT=${HEXSIM_OUT:-out/main}
rm -rf "$OUT"
./build/apps/hexsim run square --vehicle paper_hex --world changchun --out "$OUT/run"
echo "hexsim: log written to $OUT/run/log.csv (summary: $OUT/run/summary.json)"
