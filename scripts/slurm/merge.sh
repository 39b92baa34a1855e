#!/usr/bin/env bash
# Merges the shards of a Slurm batch (OUT/shard_*/results.sqlite) into OUT/results.sqlite,
# deduplicating on run_id, so `hexsim batch-report OUT` sees the whole batch.
#
#   scripts/slurm/merge.sh OUT_DIR
set -euo pipefail
[ $# -eq 1 ] || { echo "usage: merge.sh OUT_DIR" >&2; exit 2; }
OUT=$1
HERE=$(cd "$(dirname "$0")" && pwd)
if [ -z "${HEXSIM:-}" ]; then
  HEXSIM=$(command -v hexsim || echo "$HERE/../../build/apps/hexsim")
fi
shopt -s nullglob
SHARDS=("$OUT"/shard_*/results.sqlite)
[ ${#SHARDS[@]} -gt 0 ] || { echo "merge.sh: $OUT: no shard_*/results.sqlite" >&2; exit 2; }
exec "$HEXSIM" batch-merge "$OUT" "${SHARDS[@]}"
