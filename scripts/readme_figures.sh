#!/usr/bin/env bash
# Regenerates the README's tables of figures from fresh runs and writes them between their marker
# comments in README.md (`<!-- readme_figures:NAME -->` ... `<!-- /readme_figures:NAME -->`):
#   table1    the paper's Table 1: turntable, five calibrations, heading-error (README's commands)
#   compare   `hexsim compare --seeds 3` on its defaults: mean ± std per calibration
#   selftest  `hexsim gap selftest --profile ideal --trials 100` (minutes), with the machine and date
#   selftest_real  `hexsim gap selftest --profile real --trials 100` (issue 16's targets; minutes)
#   speed     the Google Benchmark programs in bench/ (minutes), printed with the machine and date
#   log171    the shared real log, per compass: calibrate --method flight, gap's absolute term and
#             its decomposition with --sim quad_x and with the identified vehicle (seconds)
#
# Usage: scripts/readme_figures.sh [--check] [NAME...]
#   default NAMEs: all five; with --check: table1 compare (the deterministic ones), and nothing is
#   written: exit 1 with a diff when README.md disagrees with the fresh run (CI, scripts/gates.sh).
# Environment: HEXSIM_BUILD_DIR (default build/, made by scripts/test.sh or scripts/setup.sh).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
build=${HEXSIM_BUILD_DIR:-$root/build}
hexsim=$build/apps/hexsim
check=0
names=()
for a in "$@"; do
  case $a in
    --check) check=1 ;;
    table1|compare|selftest|selftest_real|speed|log171) names+=("$a") ;;
    *) echo "readme_figures: unknown argument '$a' (--check, table1 compare selftest selftest_real speed log171)" >&2; exit 2 ;;
  esac
done
if ((${#names[@]} == 0)); then
  if ((check)); then names=(table1 compare log171); else names=(table1 compare log171 selftest selftest_real speed); fi
fi
[ -x "$hexsim" ] || { echo "readme_figures: no $hexsim: build first (scripts/setup.sh build)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# The machine, with its load when the script started (other work on it slows selftest and speed).
machine="$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//') ($(nproc) cores, load average $(cut -d' ' -f1 /proc/loadavg) at the start)"
date=$(date -u +%Y-%m-%d)
tables=$root/scripts/readme_tables.py

gen_table1() {
  local methods=(traditional adaptive adaptive-current compassmot px4-ls) m calibs=()
  "$hexsim" turntable --out "$work/tt" > /dev/null
  for m in "${methods[@]}"; do
    "$hexsim" calibrate "$work/tt/samples.csv" --method "$m" --out "$work/tt/$m.yaml" > /dev/null
    calibs+=(--calib "$work/tt/$m.yaml")
  done
  "$hexsim" heading-error "${calibs[@]}" --json "$work/table1.json" > /dev/null
  python3 "$tables" table1 "$work/table1.json"
}

gen_compare() {
  "$hexsim" compare --seeds 3 --no-report --out "$work/compare" > /dev/null
  python3 "$tables" compare "$work/compare/comparison.json"
}

gen_selftest() {
  # Exit 1 (a target missed) is a result, not a failure of this script.
  "$hexsim" gap selftest --profile ideal --trials 100 --json "$work/selftest.json" > /dev/null || [ $? -eq 1 ]
  python3 "$tables" selftest "$work/selftest.json" "$machine" "$date"
}

gen_selftest_real() {
  # Issue 16's targets are on the real profile; exit 1 (a target missed) is a result.
  "$hexsim" gap selftest --profile real --trials 100 --jobs "$(nproc)" --json "$work/selftest_real.json" > /dev/null ||
    [ $? -eq 1 ]
  python3 "$tables" selftest "$work/selftest_real.json" "$machine" "$date"
}

gen_log171() {
  local log=$root/data/real/ardupilot_copter_log171.bin c reports=()
  "$hexsim" import "$log" --out "$work/l171/log.csv" > /dev/null
  "$hexsim" gap diagnose --real "$work/l171/log.csv" --sim quad_x --out "$work/l171/sim" > /dev/null
  "$hexsim" gap diagnose --real "$work/l171/log.csv" --out "$work/l171/nosim" > /dev/null
  for c in mag mag2 mag3; do
    # exit 1 (a gate rejects the fit: MAG3 is uncalibrated) is a result, not a failure of this script
    "$hexsim" calibrate "$log" --method flight --compass "$c" --out "$work/l171/$c/calib.yaml" > /dev/null || [ $? -eq 1 ]
    reports+=("$work/l171/$c/calib.report.json")
  done
  python3 "$tables" log171 "$work/l171/sim/gap.json" "$work/l171/nosim/gap.json" "${reports[@]}"
}

gen_speed() {
  local b jsons=()
  for b in bench_sim bench_calib bench_gap; do
    [ -x "$build/bench/$b" ] || { echo "readme_figures: no $build/bench/$b (HEXSIM_BUILD_BENCH=ON)" >&2; exit 2; }
    # bench_gap: the 10-minute log's read and diagnoses (issue 29's < 2 s wall on both paths).
    local -a filter=()
    [ "$b" = bench_gap ] && filter=(--benchmark_filter=10min)
    "$build/bench/$b" "${filter[@]}" --benchmark_repetitions=3 --benchmark_report_aggregates_only=true \
      --benchmark_out="$work/$b.json" --benchmark_out_format=json > /dev/null
    jsons+=("$work/$b.json")
  done
  python3 "$tables" speed "$machine" "$date" "${jsons[@]}"
}

status=0
for n in "${names[@]}"; do
  t0=$SECONDS
  "gen_$n" > "$work/$n.md" 2> "$work/$n.log" || { cat "$work/$n.log" >&2; echo "readme_figures: $n: a run failed" >&2; exit 1; }
  if ((check)); then
    python3 "$tables" check README.md "$n" "$work/$n.md" || status=1
  else
    python3 "$tables" splice README.md "$n" "$work/$n.md"
    echo "readme_figures: $n regenerated in README.md"
  fi
  echo "readme_figures: $n took $((SECONDS - t0)) s"
done
exit $status
