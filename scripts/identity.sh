#!/usr/bin/env bash
# Byte-identity check for refactors that must not change results (issue 21): flies every shipped
# mission on every shipped vehicle (ESKF, seed 3), the square on truth and complementary, the compare
# command (paper default, Table 1 included, 2 seeds), a gap selftest and a step response with two
# hexsim binaries, and diffs every output. wall_s (wall clock) is dropped from the JSON files,
# printed paths and the compare progress order (its runs finish in any order) are normalised.
#   scripts/identity.sh BEFORE_BIN AFTER_BIN OUTDIR      (exit 0: identical)
set -u
[ $# -eq 3 ] || { echo "usage: $0 BEFORE_BIN AFTER_BIN OUTDIR" >&2; exit 2; }
export HEXSIM_DATA_DIR=${HEXSIM_DATA_DIR:-$(cd "$(dirname "$0")/.." && pwd)}
fly() {
  local H=$1 O=$2
  rm -rf "$O"; mkdir -p "$O"
  for m in climb_cruise_square figure_eight lawnmower payload_change payload_pickup_drop square; do
    for v in default_hex paper_hex quad_x; do
      "$H" run $m --vehicle $v --seed 3 --out "$O/run_${m}_$v" > "$O/run_${m}_$v.stdout" 2>&1; echo "rc $?" >> "$O/run_${m}_$v.stdout"
    done
  done
  for e in truth complementary; do "$H" run square --estimator $e --seed 2 --out "$O/run_sq_$e" > /dev/null 2>&1; done
  "$H" compare --seeds 2 --out "$O/compare" 2>&1 | sort > "$O/compare.stdout"
  "$H" gap selftest --trials 3 --threshold-trials 2 --json "$O/gap.json" > "$O/gap.stdout" 2>&1
  "$H" step --axis roll --size 10 --out "$O/step" > "$O/step.stdout" 2>&1
  find "$O" -name '*.json' | while read -r f; do jq -S 'del(.. | .wall_s?)' "$f" > "$f.tmp" && mv "$f.tmp" "$f"; done
  find "$O" \( -name '*.png' -o -name '*.html' \) -delete
  find "$O" -name '*.stdout' | while read -r f; do sed -i "s|$O||g" "$f"; done
}
fly "$1" "$3/before"
fly "$2" "$3/after"
diff -r "$3/before" "$3/after" && echo "identity: byte-identical"
