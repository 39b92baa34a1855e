#!/usr/bin/env bash
# Byte-identity check for refactoring commits (issue 21): runs the same fixed-seed commands with two
# hexsim binaries and compares every file they write and every stdout, ignoring only what is not
# reproducible by design (wall_s, host, finished_at: CONTRACTS.md; pictures are compared too).
# Commands: every shipped mission on every shipped vehicle (ESKF, seed 3), the square on truth and
# complementary, gap diagnose of a run, turntable -> calibrate -> heading-error (Table 1), compare
# (Table 1 included), batch + batch-report, gap selftest, step / freqresp / disturb.
#   [REUSE_OLD=1] [QUICK=1] scripts/identity.sh OLD_HEXSIM NEW_HEXSIM [SCRATCH_DIR]
# Exit 0 when every output is identical. REUSE_OLD=1 keeps SCRATCH/old from an earlier call with the
# same OLD binary. QUICK=1 flies the square only on paper_hex instead of the mission x vehicle grid.
# Uses --jobs 2 (the machine's budget).
set -euo pipefail
[[ $# -ge 2 && $# -le 3 ]] || { echo "usage: $0 OLD_HEXSIM NEW_HEXSIM [SCRATCH_DIR]" >&2; exit 2; }
old=$1 new=$2 scratch=${3:-$(mktemp -d)}
export HEXSIM_DATA_DIR=${HEXSIM_DATA_DIR:-$(cd "$(dirname "$0")/.." && pwd)}
outputs() {  # BIN DIR: every command runs in DIR with relative paths, so stdout names no scratch path
  local bin d=$2
  bin=$(realpath "$1")
  rm -rf "$d" && mkdir -p "$d"
  ( cd "$d" && outputs_here "$bin" )
}
fly_grid() {
  local bin=$1 missions=(climb_cruise_square figure_eight lawnmower payload_change payload_pickup_drop square)
  local vehicles=(default_hex paper_hex quad_x)
  if [[ "${QUICK:-0}" == 1 ]]; then missions=(square) vehicles=(paper_hex); fi
  for m in "${missions[@]}"; do
    for v in "${vehicles[@]}"; do
      local rc=0
      "$bin" run "$m" --vehicle "$v" --seed 3 --out "grid/$m.$v" > "grid/$m.$v.stdout" 2>&1 || rc=$?
      echo "rc $rc" >> "grid/$m.$v.stdout"
    done
  done
  for e in truth complementary; do "$bin" run square --estimator $e --seed 2 --out "est_$e" > "est_$e.stdout"; done
}
outputs_here() {
  local bin=$1 d=.
  mkdir -p grid && fly_grid "$bin"
  "$bin" run square --vehicle paper_hex --world changchun --calibration adaptive --seed 3 --duration 25 \
    --out "$d/run" > "$d/run.stdout"
  "$bin" gap diagnose --real "$d/run/log.csv" --sim paper_hex --out "$d/gap" > "$d/gap.stdout" || true
  "$bin" turntable --vehicle paper_hex --world changchun --out "$d/tt" > "$d/tt.stdout"
  "$bin" calibrate "$d/tt/samples.csv" --method adaptive --out "$d/adaptive.yaml" > "$d/cal.stdout" || true
  "$bin" calibrate "$d/tt/samples.csv" --method traditional --out "$d/traditional.yaml" >> "$d/cal.stdout" || true
  "$bin" heading-error --calib "$d/traditional.yaml" --calib "$d/adaptive.yaml" --vehicle paper_hex \
    --world changchun --json "$d/table1.json" > "$d/table1.stdout"
  "$bin" compare climb_cruise_square --calibrations none,traditional,adaptive --seeds 2 --duration 30 --jobs 2 \
    --out "$d/compare" > "$d/compare.stdout"
  "$bin" batch example --jobs 2 --out "$d/batch" > "$d/batch.stdout" 2>/dev/null || true
  "$bin" batch-report "$d/batch" > "$d/batch_report.stdout" || true
  "$bin" gap selftest --trials 2 --threshold-trials 2 --seed 5 --json "$d/selftest.json" > "$d/selftest.stdout" || true
  "$bin" step --axis roll --size 10 --out "$d/step" > "$d/step.stdout"
  "$bin" freqresp --axis pitch --periods 2 --out "$d/freqresp" > "$d/freqresp.stdout" || true
  "$bin" disturb --gust 3,0,0 --gust-duration 2 --duration 8 --out "$d/disturb" > "$d/disturb.stdout" || true
}
scratch=$(realpath "$scratch")
if [[ "${REUSE_OLD:-0}" != 1 || ! -d "$scratch/old" ]]; then outputs "$old" "$scratch/old"; fi
outputs "$new" "$scratch/new"
python3 - "$scratch/old" "$scratch/new" <<'PY'
import json, os, re, sqlite3, sys
old, new = sys.argv[1], sys.argv[2]
VOLATILE = {"wall_s", "host", "finished_at"}
def scrub(x):
    if isinstance(x, dict): return {k: scrub(v) for k, v in x.items() if k not in VOLATILE}
    if isinstance(x, list): return [scrub(v) for v in x]
    return x
def files(root):
    out = set()
    for d, _, fs in os.walk(root):
        for f in fs: out.add(os.path.relpath(os.path.join(d, f), root))
    return out
def load(path):
    if path.endswith(".stdout"):  # wall times are not outputs
        with open(path) as f: text = f.read()
        return re.sub(r"\(\d+ this time, [0-9.]+ s\)", "(N this time, T s)", text)
    if path.endswith(".json"):
        with open(path) as f: return scrub(json.load(f))
    if path.endswith(".sqlite"):
        con = sqlite3.connect(path)
        cols = [r[1] for r in con.execute("PRAGMA table_info(runs)") if r[1] not in VOLATILE]
        rows = con.execute(f"SELECT {','.join(cols)} FROM runs ORDER BY run_id").fetchall()
        return [tuple(scrub(json.loads(v)) if isinstance(v, str) and v.startswith("{") else v for v in r) for r in rows]
    with open(path, "rb") as f: return f.read()
fo, fn = files(old), files(new)
bad = sorted(fo ^ fn)
same = 0
for p in sorted(fo & fn):
    if p.endswith((".sqlite-wal", ".sqlite-shm")): continue
    if load(os.path.join(old, p)) != load(os.path.join(new, p)): bad.append(p)
    else: same += 1
print(f"identity: compared {len(fo & fn)} files: {'identical' if not bad else 'DIFFERENT: ' + ', '.join(bad)}")
sys.exit(1 if bad else 0)
PY
