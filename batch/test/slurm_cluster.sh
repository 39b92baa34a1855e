#!/usr/bin/env bash
# Starts a real single-node Slurm cluster (munged + slurmctld + slurmd) under a temporary
# directory, submits a small batch as a 4-task job array with scripts/slurm/submit.sh --merge (the
# array, then a dependent job running scripts/slurm/merge.sh), waits, and checks every run is
# present exactly once in the merged results.
# Recipe: /work/shared/design/SLURM_NOTES.md. Exit 0 pass, 1 fail, 77 skip (packages missing).
#   slurm_cluster.sh HEXSIM_EXE SOURCE_DIR BATCH_YAML
set -uo pipefail
HEXSIM=$1 SRC=$2 BATCH=$3
TASKS=4
for exe in munged slurmctld slurmd sbatch squeue sinfo; do
  command -v "$exe" >/dev/null || { echo "SKIP: $exe not installed (Debian packages slurm-wlm, munge)"; exit 77; }
done
D=$(mktemp -d /tmp/hexsim-slurm.XXXXXX)
chmod 755 "$D"
mkdir -p "$D/run" "$D/key" "$D/log" "$D/state" "$D/spool" "$D/out"
chmod 755 "$D/run"
chmod 700 "$D/key"
stop() {
  for p in slurmd slurmctld munged; do
    [ -f "$D/run/$p.pid" ] && kill "$(cat "$D/run/$p.pid")" 2>/dev/null
  done
  # Wait (briefly) until they are gone or zombies.
  for _ in $(seq 50); do
    alive=0
    for p in slurmd slurmctld munged; do
      if [ -f "$D/run/$p.pid" ]; then
        st=$(ps -o stat= -p "$(cat "$D/run/$p.pid")" 2>/dev/null | tr -d ' ')
        [ -n "$st" ] && [ "${st:0:1}" != Z ] && alive=1
      fi
    done
    [ $alive = 0 ] && break
    sleep 0.1
  done
  [ -n "${KEEP_SLURM_DIR:-}" ] || rm -rf "$D"
}
trap stop EXIT
fail() { echo "FAIL: $*"; for f in "$D"/log/*.log "$D"/out/slurm/*.out; do [ -f "$f" ] && { echo "--- $f"; tail -20 "$f"; }; done; exit 1; }

dd if=/dev/urandom of="$D/key/munge.key" bs=1024 count=1 status=none
chmod 400 "$D/key/munge.key"
munged --key-file="$D/key/munge.key" --socket="$D/run/munge.sock" --pid-file="$D/run/munged.pid" \
  --log-file="$D/log/munged.log" --seed-file="$D/run/munge.seed" || fail "munged did not start"

HOST=$(hostname -s)
NODE=$(slurmd -C | head -1)  # NodeName=... CPUs=... RealMemory=... as this machine has them
PORT=$((20000 + RANDOM % 20000))
cat > "$D/slurm.conf" <<CONF
ClusterName=hexsimtest
SlurmctldHost=$HOST
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$D/run/munge.sock
SlurmctldPort=$PORT
SlurmdPort=$((PORT + 1))
StateSaveLocation=$D/state
SlurmdSpoolDir=$D/spool
SlurmctldPidFile=$D/run/slurmctld.pid
SlurmdPidFile=$D/run/slurmd.pid
SlurmctldLogFile=$D/log/slurmctld.log
SlurmdLogFile=$D/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
JobAcctGatherType=jobacct_gather/none
MailProg=/bin/true
ReturnToService=2
SchedulerParameters=batch_sched_delay=0,sched_min_interval=0
$NODE State=UNKNOWN
PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF=$D/slurm.conf
slurmctld -i -f "$SLURM_CONF" || fail "slurmctld did not start"
slurmd -f "$SLURM_CONF" || fail "slurmd did not start"
for _ in $(seq 100); do
  [ "$(sinfo -h -o %t 2>/dev/null)" = idle ] && break
  sleep 0.1
done
[ "$(sinfo -h -o %t 2>/dev/null)" = idle ] || fail "node not idle: $(sinfo 2>&1)"

IDS=$(HEXSIM=$HEXSIM "$SRC/scripts/slurm/submit.sh" "$BATCH" "$D/out" --tasks $TASKS --jobs 1 --merge) ||
  fail "submit.sh failed"
JOB=$(echo "$IDS" | sed -n 1p)
MJOB=$(echo "$IDS" | sed -n 2p)
[ -n "$JOB" ] && [ -n "$MJOB" ] || fail "submit.sh printed '$IDS', expected two job ids"
echo "submitted array job $JOB, merge job $MJOB"
for _ in $(seq 450); do
  [ -z "$(squeue -h -j "$JOB,$MJOB" 2>/dev/null)" ] && break
  sleep 0.1
done
[ -z "$(squeue -h -j "$JOB,$MJOB" 2>/dev/null)" ] || fail "jobs $JOB/$MJOB still queued after 45 s"
for i in $(seq 0 $((TASKS - 1))); do
  [ -f "$D/out/shard_$i/results.sqlite" ] || fail "task $i wrote no shard_$i/results.sqlite"
done
[ -f "$D/out/results.sqlite" ] || fail "the merge job wrote no results.sqlite"
cat "$D/out/slurm/merge.out"
# Every run of the batch exactly once.
"$HEXSIM" batch "$BATCH" --list | cut -d' ' -f1 | sort > "$D/expected.txt"
"$HEXSIM" batch-report "$D/out" --no-plots --json "$D/report.json" >/dev/null || fail "batch-report failed"
python3 - "$D/out/results.sqlite" "$D/expected.txt" <<'PY' || fail "merged results do not match the batch"
import sqlite3, sys
rows = [r[0] for r in sqlite3.connect(sys.argv[1]).execute("SELECT run_id FROM runs")]
expected = [l.strip() for l in open(sys.argv[2]) if l.strip()]
assert len(expected) >= 4, expected
assert sorted(rows) == sorted(expected), (sorted(rows), sorted(expected))
assert len(set(rows)) == len(rows)
print(f"{len(rows)} runs, each exactly once, from {len(expected)} expected")
PY
echo PASS
