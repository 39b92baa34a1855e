#!/usr/bin/env bash
# Withheld effects on real baselines (issue 29): inject.py plants a known effect in each corpus
# DataFlash log's compasses that have a usable current (internal ones; the reference's index says
# which), withheld.py diagnoses every copy with `gap diagnose` and judges it against the truth.
#   bash scripts/corpus/withheld.sh HEXSIM [CORPUS_DIR=/work/corpus] [README=README.md] [SEED=1]
# Replaces README's <!-- readme_figures:withheld --> block. Needs the logs (not in the repository)
# and reference.json (scripts/corpus/run.sh writes it); runs where the logs are, not in CI.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
hexsim=$(realpath "$1")
corpus=$(realpath "${2:-/work/corpus}")
readme=${3:-$here/../../README.md}
seed=${4:-1}
py=/usr/bin/python3
work=$(mktemp -d /tmp/hexsim-withheld.XXXXXX)
trap 'rm -rf "$work"' EXIT
mapfile -t targets < <("$py" - "$corpus/reference.json" <<'PY'
import json, sys
for r in json.load(open(sys.argv[1])):
    if not r["log"].endswith(".bin") or not r.get("current", {}).get("usable"):
        continue
    for c in r["compasses"]:
        if not c.get("external") and c.get("status") == "fitted":
            print("%s:%s" % (r["log"], c["compass"]))
PY
)
"$py" "$here/withheld.py" --hexsim "$hexsim" --work "$work/runs" --seed "$seed" --jobs "$(nproc)" "${targets[@]}" > "$work/table.txt"
{
  echo "Written by \`bash scripts/corpus/withheld.sh\` on $(date -u +%Y-%m-%d) with hexsim at commit" \
       "$(git -C "$(dirname "$hexsim")" rev-parse --short HEAD 2>/dev/null || echo unknown), seed $seed:" \
       "$(tail -1 "$work/table.txt")."
  echo
  echo "| log | compass | planted | judged | what gap diagnose said |"
  echo "|---|---|---|---|---|"
  grep '^|' "$work/table.txt"
} > "$work/section.md"
"$py" "$here/../readme_tables.py" splice "$readme" withheld "$work/section.md"
echo "withheld: $(tail -1 "$work/table.txt"); README block 'withheld' updated"
