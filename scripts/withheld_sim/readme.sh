#!/usr/bin/env bash
# Withheld cases through the user's path (scripts/withheld_sim), per form, into the README.
#   bash scripts/withheld_sim/readme.sh HEXSIM [SEED=2026] [CASES=72] [README=README.md] [OUT=tmp]
# Runs withheld_sim.py (about 20 min for 72 cases on 2 cores) and replaces README's
# <!-- readme_figures:withheld_sim --> block with the pass count per form and path. REUSE=1 with an
# OUT that holds a finished run's results.json writes the block from it without running again.
# COMMIT names the commit the binary was built at where it was copied out of its tree. BLOCK names the
# README block (default withheld_sim; withheld_sim_fresh: a seed the project has not developed against).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
hexsim=$(realpath "$1")
seed=${2:-2026}
cases=${3:-72}
readme=${4:-$here/../../README.md}
out=${5:-$(mktemp -d /tmp/hexsim-withheld-sim.XXXXXX)}
py=/usr/bin/python3
if [[ "${REUSE:-0}" != 1 || ! -f "$out/results.json" ]]; then
  "$py" "$here/withheld_sim.py" --seed "$seed" --cases "$cases" --jobs 2 --hexsim "$hexsim" --out "$out" > "$out/run.log"
fi
"$py" - "$out/results.json" "${COMMIT:-$(git -C "$(dirname "$hexsim")" rev-parse --short HEAD 2>/dev/null || echo unknown)}" \
    "$cases" > "$out/section.md" <<'PY'
import json, sys, datetime
d = json.load(open(sys.argv[1]))
counts = d["counts"]
forms = []
for key in counts:
    f = key.split("|")[0]
    if f not in forms:
        forms.append(f)
tot = {"sim": [0, 0], "nosim": [0, 0]}
print("Written by `bash scripts/withheld_sim/readme.sh` on %s with hexsim at commit %s, seed %s, %s cases "
      "(judged cases only: a flight lost or a lag the current cannot show is not judged)." % (
          datetime.date.today().isoformat(), sys.argv[2], d["seed"], sys.argv[3]))
print()
print("| form | `--sim` (the unmodified vehicle) | without `--sim` (identified) |")
print("|---|---|---|")
for f in forms:
    cells = []
    for p in ("sim", "nosim"):
        c = counts.get("%s|%s" % (f, p))
        cells.append("%d/%d" % tuple(c) if c else "–")
        if c:
            tot[p][0] += c[0]
            tot[p][1] += c[1]
    print("| %s | %s | %s |" % (f, cells[0], cells[1]))
print("| **all** | **%d/%d** | **%d/%d** |" % (tot["sim"][0], tot["sim"][1], tot["nosim"][0], tot["nosim"][1]))
PY
block=${BLOCK:-withheld_sim}
"$py" "$here/../readme_tables.py" splice "$readme" "$block" "$out/section.md"
echo "withheld_sim: $(tail -1 "$out/section.md"); README block '$block' updated ($out)"
