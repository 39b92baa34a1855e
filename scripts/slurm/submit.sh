#!/usr/bin/env bash
# Turns a hexsim batch into a Slurm job array: task i runs `hexsim batch --shard i/N` into
# OUT/shard_i (resumable: a requeued task skips its finished runs); with --merge, a dependent job
# then merges the shards into OUT/results.sqlite (scripts/slurm/merge.sh).
#
#   scripts/slurm/submit.sh BATCH.yaml OUT_DIR [--tasks N] [--jobs J] [--merge] [-- SBATCH_ARGS...]
#
# N array tasks (default 4), J worker processes per task (default 1; asked of Slurm as
# --cpus-per-task). HEXSIM names the executable (default: `hexsim` on PATH, else build/apps/hexsim).
# Prints the array job id (and the merge job id with --merge) on stdout.
set -euo pipefail
usage() { sed -n '2,11p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
[ $# -ge 2 ] || usage
BATCH=$1 OUT=$2
shift 2
TASKS=4 JOBS=1 MERGE=0
EXTRA=()
while [ $# -gt 0 ]; do
  case "$1" in
    --tasks) TASKS=$2; shift 2 ;;
    --jobs) JOBS=$2; shift 2 ;;
    --merge) MERGE=1; shift ;;
    --) shift; EXTRA=("$@"); break ;;
    *) echo "submit.sh: unknown argument '$1'" >&2; usage ;;
  esac
done
[[ "$TASKS" =~ ^[1-9][0-9]*$ ]] || { echo "submit.sh: --tasks: expected a positive integer" >&2; exit 2; }
[[ "$JOBS" =~ ^[1-9][0-9]*$ ]] || { echo "submit.sh: --jobs: expected a positive integer" >&2; exit 2; }
HERE=$(cd "$(dirname "$0")" && pwd)
if [ -z "${HEXSIM:-}" ]; then
  HEXSIM=$(command -v hexsim || echo "$HERE/../../build/apps/hexsim")
fi
HEXSIM=$(realpath "$HEXSIM")
[ -x "$HEXSIM" ] || { echo "submit.sh: $HEXSIM: no hexsim executable (set HEXSIM)" >&2; exit 2; }
# A name under worlds/batches/ stays a name; a path becomes absolute (tasks run in OUT).
[ -f "$BATCH" ] && BATCH=$(realpath "$BATCH")
# Validate the batch file here, once, rather than in N failing tasks.
"$HEXSIM" batch "$BATCH" --list >/dev/null
mkdir -p "$OUT/slurm"
OUT=$(realpath "$OUT")
q() { printf '%q' "$1"; }
cat > "$OUT/slurm/task.sh" <<TASK
#!/usr/bin/env bash
# One array task of a hexsim batch (written by scripts/slurm/submit.sh).
set -euo pipefail
exec $(q "$HEXSIM") batch $(q "$BATCH") --shard "\${SLURM_ARRAY_TASK_ID}/$TASKS" --jobs $JOBS --resume \\
  --out $(q "$OUT")/shard_\${SLURM_ARRAY_TASK_ID}
TASK
chmod +x "$OUT/slurm/task.sh"
JOB=$(sbatch --parsable --array=0-$((TASKS - 1)) --cpus-per-task="$JOBS" --job-name=hexsim-batch \
  --chdir="$OUT" --output="$OUT/slurm/task_%a.out" ${EXTRA[@]+"${EXTRA[@]}"} "$OUT/slurm/task.sh")
JOB=${JOB%%;*}
echo "$JOB"
if [ "$MERGE" = 1 ]; then
  MJOB=$(sbatch --parsable --dependency=afterany:"$JOB" --job-name=hexsim-merge --chdir="$OUT" \
    --output="$OUT/slurm/merge.out" --wrap="HEXSIM=$(q "$HEXSIM") $(q "$HERE/merge.sh") $(q "$OUT")")
  echo "${MJOB%%;*}"
fi
