#!/usr/bin/env bash
# Byte-identity check for refactoring commits: runs the same fixed-seed commands with two hexsim
# binaries (run, gap diagnose of that run, turntable/calibrate/heading-error, compare, batch,
# batch-report, gap selftest) and compares every file they write (and their stdout), ignoring only what is not
# reproducible by design (wall_s, host, finished_at; CONTRACTS.md).
#   [REUSE_OLD=1] scripts/same_outputs.sh OLD_HEXSIM NEW_HEXSIM [SCRATCH_DIR]
# Exit 0 when every output is identical. Uses --jobs 2 (the machine's budget); takes ~2 min per binary.
set -euo pipefail
old=$1 new=$2 scratch=${3:-$(mktemp -d)}
export HEXSIM_DATA_DIR=${HEXSIM_DATA_DIR:-$(cd "$(dirname "$0")/.." && pwd)}
outputs() {  # BIN DIR: every command runs in DIR with relative paths, so stdout names no scratch path
  local bin d=$2
  bin=$(realpath "$1")
  rm -rf "$d" && mkdir -p "$d"
  ( cd "$d" && outputs_here "$bin" )
}
outputs_here() {
  local bin=$1 d=.
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
}
scratch=$(realpath "$scratch")
# REUSE_OLD=1 keeps SCRATCH/old from an earlier call with the same OLD binary.
if [[ "${REUSE_OLD:-0}" != 1 || ! -d "$scratch/old" ]]; then outputs "$old" "$scratch/old"; fi
outputs "$new" "$scratch/new"
python3 - "$scratch/old" "$scratch/new" <<'PY'
import json, os, sqlite3, sys
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
import re
def load(path):
    if path.endswith(".stdout"):  # paths under the scratch dir and wall times are not outputs
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
bad = sorted((fo ^ fn))
for p in sorted(fo & fn):
    if p.endswith((".sqlite-wal", ".sqlite-shm")): continue
    if load(os.path.join(old, p)) != load(os.path.join(new, p)): bad.append(p)
print(f"compared {len(fo & fn)} files: {'identical' if not bad else 'DIFFERENT: ' + ', '.join(bad)}")
sys.exit(1 if bad else 0)
PY
