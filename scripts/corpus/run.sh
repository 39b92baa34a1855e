#!/usr/bin/env bash
# Real-log corpus check (issue 29 item 8): the independent reference and hexsim on every log.
#   [SOURCES=scripts/corpus/sources_fresh.json BLOCK=corpus_fresh] \
#   bash scripts/corpus/run.sh HEXSIM [CORPUS_DIR=/work/corpus] [README=README.md]
# Writes CORPUS_DIR/README.md (the index), reference.{json,md}, check.{json,md}, STATUS.md, and
# replaces README's <!-- readme_figures:BLOCK --> block (default: corpus) with the table, the date and
# the commit. SOURCES names the logs (default: sources.json here; gather.py fetches them); a BLOCK
# other than `corpus` gets the count and the failing rows only (the full table stays in CORPUS_DIR).
# Needs the logs (not in the repository: see CORPUS_DIR/README.md for sources and licences),
# /usr/bin/python3 with numpy (Debian python3-numpy); runs where the logs are, not in CI.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
hexsim=$(realpath "$1")
corpus=$(realpath "${2:-/work/corpus}")
readme=${3:-$here/../../README.md}
sources=$(realpath "${SOURCES:-$here/sources.json}")
block=${BLOCK:-corpus}
py=/usr/bin/python3
work=$(mktemp -d /tmp/hexsim-corpus.XXXXXX)
trap 'rm -rf "$work"' EXIT
"$py" "$here/reference.py" --selftest
"$py" "$here/index.py" "$corpus"
mapfile -t logs < <("$py" -c 'import json,sys; [print(sys.argv[1]+"/"+s["file"]) for s in json.load(open(sys.argv[2]))]' "$corpus" "$sources")
"$py" "$here/reference.py" --json "$corpus/reference.json" --md "$corpus/reference.md" "${logs[@]}" > /dev/null
"$py" "$here/check_hexsim.py" --hexsim "$hexsim" --sources "$sources" --work "$work" \
    --json "$corpus/check.json" --md "$corpus/check.md" --status "$corpus/STATUS.md" "$corpus" > /dev/null
if [ "$block" != corpus ]; then
  {
    echo "Written by \`SOURCES=$(basename "$sources") BLOCK=$block bash scripts/corpus/run.sh\` on" \
         "$(date -u +%Y-%m-%d) with hexsim at commit" \
         "$(git -C "$(dirname "$hexsim")" rev-parse --short HEAD 2>/dev/null || echo unknown)."
    echo
    # the binary's and the corpus's paths are this machine's: the commit and the set's name say it
    sed -n '3,$p' "$corpus/STATUS.md" | sed -E "s#^hexsim [^ ]+ \(#hexsim (#; s#, corpus [^,]+,#, $(basename "$sources" .json),#"
  } > "$work/section.md"
  "$py" "$here/../readme_tables.py" splice "$readme" "$block" "$work/section.md"
  echo "corpus: $(head -3 "$corpus/STATUS.md" | tail -1 | grep -o '[0-9]* of [0-9]* compass rows pass')" \
       "in $corpus; README block '$block' updated"
  exit 0
fi
{
  echo "Written by \`bash scripts/corpus/run.sh\` on $(date -u +%Y-%m-%d) with hexsim at commit" \
       "$(git -C "$(dirname "$hexsim")" rev-parse --short HEAD 2>/dev/null || echo unknown)" \
       "(its \`--version\`: $("$hexsim" --version 2>/dev/null | head -1))."
  echo
  echo "Independent reference per compass (scripts/corpus/reference.py: own DataFlash/ULog readers, numpy"
  echo "least squares of m = R_NBᵀ·B_N + c + k·I over the flight window, 10-s block bootstrap):"
  echo
  cat "$corpus/reference.md"
  echo
  echo "hexsim against it (scripts/corpus/check_hexsim.py; PASS/FAIL as issue 29's \"Done when\"):"
  echo
  cat "$corpus/check.md"
} > "$work/section.md"
"$py" "$here/../readme_tables.py" splice "$readme" corpus "$work/section.md"
echo "corpus: $(grep -c . "$corpus/STATUS.md") lines in $corpus/STATUS.md; README block 'corpus' updated"
