#!/usr/bin/env bash
# Sets up, builds and runs every test (the README's second command).
# chromium: the browser test opens the HTML reports headless (test/browser_test.cc; skipped without it).
set -euo pipefail
cd "$(dirname "$0")/.."
HEXSIM_EXTRA_PACKAGES="slurm-wlm munge python3 chromium ${HEXSIM_EXTRA_PACKAGES:-}" scripts/setup.sh build
ctest --test-dir build -j"$(nproc)" --output-on-failure --timeout 600
