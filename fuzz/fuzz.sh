#!/usr/bin/env bash
# Builds and runs hexsim's libFuzzer targets (clang + libclang-rt dev package).
#
#   fuzz/fuzz.sh                # CI: each target -runs=100000 with -max_len=65536
#   fuzz/fuzz.sh 600            # each target for 600 s on every worker (a long run: before releases)
#   fuzz/fuzz.sh -runs=1000000  # any libFuzzer limit flags, e.g. -runs=100000 -max_total_time=120
#                               # (CI: whichever comes first, per target)
#
# Build dir: build-fuzz beside the sources (HEXSIM_FUZZ_BUILD_DIR overrides). Seeds come from
# fuzz/corpus/<target> (cut from the real log by fuzz/make_corpus.sh) and are only read; new inputs
# go to a scratch corpus, crashes to build-fuzz/artifacts/. Exit status: non-zero on any finding.
# Seeds for batch_yaml are the shipped batch file and a hand-written one using every key.
# fuzz_cli (the command line's flag parsing, every subcommand) links the whole simulator, so it is
# built in the sanitizer build (scripts/gates.sh sanitize: HEXSIM_FUZZ_CLI_BUILD_DIR, default
# build-gates-asan beside the sources), which already holds every library: only the commands'
# sources compile again. Where that build is not configured, fuzz_cli is skipped with a line saying so.
# The mutation seed is fixed (HEXSIM_FUZZ_SEED, default 1) so that a CI run is repeatable: the same
# sources explore the same inputs. Set HEXSIM_FUZZ_SEED=0 for a fresh random seed on long runs, and
# keep every crash that one finds in fuzz/corpus/<target> as a regression seed.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${HEXSIM_FUZZ_BUILD_DIR:-$root/build-fuzz}
if (($#)); then limit=("$@"); else limit=(-runs=100000); fi
if [[ ${limit[0]} =~ ^[0-9]+$ ]]; then limit=(-max_total_time="${limit[0]}"); fi
# Tests stay ON: cmake/hexsim.cmake (hexsim_folder) fails to configure with them OFF; only the two
# fuzz targets are built.
launcher=()
if command -v ccache > /dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi

mkdir -p "$build"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DHEXSIM_BUILD_FUZZ=ON -DHEXSIM_BUILD_TESTS=ON \
  -DHEXSIM_BUILD_BENCH=OFF "${launcher[@]}" > "$build/configure.log" 2>&1 ||
  { cat "$build/configure.log"; exit 1; }
ninja -C "$build" -j"${HEXSIM_FUZZ_JOBS:-2}" fuzz_dataflash fuzz_flightlog_csv fuzz_ulog fuzz_batch_yaml fuzz_mavlink

# A smaller ASan quarantine (default 256 MB) keeps reused memory hot: fresh pages for every freed
# buffer cost ~15% of a run in page faults. Use-after-free within the last 64 MB is still caught.
export ASAN_OPTIONS=${ASAN_OPTIONS:-quarantine_size_mb=64}
mkdir -p "$build/artifacts"
# Each target is fuzzed by HEXSIM_FUZZ_JOBS independent workers (default: the build's job count),
# each with its own mutation seed (seed, seed+1, ...) and scratch corpus; a -runs=N budget is split
# between them so the target still gets N executions in all, in 1/jobs of the wall time.
workers=${HEXSIM_FUZZ_WORKERS:-${HEXSIM_FUZZ_JOBS:-2}}
seed=${HEXSIM_FUZZ_SEED:-1}
cli_build=${HEXSIM_FUZZ_CLI_BUILD_DIR:-$root/build-gates-asan}
targets=(dataflash flightlog_csv ulog batch_yaml mavlink)
declare -A binary
for t in "${targets[@]}"; do binary[$t]=$build/fuzz/fuzz_$t; done
if [ -f "$cli_build/build.ninja" ] && grep -q '^HEXSIM_SANITIZE:BOOL=ON' "$cli_build/CMakeCache.txt"; then
  ninja -C "$cli_build" -j"${HEXSIM_FUZZ_JOBS:-2}" fuzz_cli
  targets+=(cli)
  binary[cli]=$cli_build/apps/fuzz_cli
else
  echo "fuzz_cli: skipped: no sanitizer build at $cli_build (run scripts/gates.sh sanitize first)"
fi
for target in "${targets[@]}"; do
  wlimit=()
  for l in "${limit[@]}"; do
    if [[ $l =~ ^-runs=([0-9]+)$ ]]; then l=-runs=$(( (BASH_REMATCH[1] + workers - 1) / workers )); fi
    wlimit+=("$l")
  done
  echo "fuzz_$target: ${limit[*]} -max_len=65536 ($workers workers, ${wlimit[*]} each)"
  t0=$SECONDS
  pids=()
  scratch=()
  for ((w = 0; w < workers; ++w)); do
    scratch[w]=$(mktemp -d)
    wseed=$seed
    [ "$seed" = 0 ] || wseed=$((seed + w))
    "${binary[$target]}" "${scratch[w]}" "$root/fuzz/corpus/$target" -max_len=65536 "${wlimit[@]}" \
      -seed="$wseed" -print_final_stats=1 -artifact_prefix="$build/artifacts/${target}-" \
      > "$build/fuzz_$target.$w.log" 2>&1 &
    pids[w]=$!
  done
  failed=()
  for ((w = 0; w < workers; ++w)); do
    wait "${pids[w]}" || failed+=("$w")
    rm -rf "${scratch[w]}"
  done
  if ((${#failed[@]})); then
    for w in "${failed[@]}"; do tail -60 "$build/fuzz_$target.$w.log"; done
    echo "fuzz_$target: FAILED (logs: $build/fuzz_$target.{${failed[*]// /,}}.log)" >&2
    exit 1
  fi
  runs=$(cat "$build/fuzz_$target".*.log | awk '/^stat::number_of_executed_units:/ { n += $2 } END { print n + 0 }')
  secs=$((SECONDS - t0))
  echo "fuzz_$target: $runs executions in $secs s ($(( runs / (secs > 0 ? secs : 1) )) exec/s over $workers workers)"
done
