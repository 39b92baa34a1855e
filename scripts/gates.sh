#!/usr/bin/env bash
# hexsim's quality gates (issue 11), run by .ci/run after the README's test command (scripts/test.sh).
# Each stage has its own build directory beside the sources; the first failing stage stops the run.
#
#   1+2  sanitize   clang, -Werror (HEXSIM_WERROR) + ASan/UBSan (HEXSIM_SANITIZE) in ONE build, then every
#                   ctest test under the sanitizers (any report aborts the test)     build-gates-asan/
#                   (Python module off: an ASan-instrumented module cannot load into python3)
#   3    tidy       clang-tidy 14 with the checked-in .clang-tidy over every project .cc: zero findings
#                   (configure only: it needs compile_commands.json, not objects)     build-gates-tidy/
#                   Files unchanged since a clean run (same preprocessed input, flags, tool, config:
#                   .ci/tidy-clean.txt, scripts/tidy_cache.py) are not checked again; HEXSIM_TIDY_FULL=1
#   4    fuzz       fuzz/fuzz.sh: each libFuzzer target -runs=100000 -max_len=65536, at most 240 s
#                   per target (the CI budget)                                         build-gates-fuzz/
#   5    determinism  the same runs (truth loop; paper_hex with turntable, fits, adaptive compensator
#                   and ESKF) with the release binary (build/, -O3, made by scripts/test.sh) and the
#                   sanitizer binary (-O1 + ASan/UBSan): log.csv byte for byte
#   6    readme     README.md's deterministic tables (Table 1, compare, log171) agree with a fresh run of the
#                   release binary: scripts/readme_figures.sh --check (made by scripts/test.sh)
#
# Usage: scripts/gates.sh [STAGE...]     (default: all stages; e.g. `scripts/gates.sh tidy fuzz`)
# Environment: HEXSIM_GATES_JOBS (default: nproc), HEXSIM_TIDY_FILES (a regex restricting the .cc files
# clang-tidy checks; default: all).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
jobs=${HEXSIM_GATES_JOBS:-$(nproc)}
stages=("$@")
((${#stages[@]})) || stages=(sanitize tidy fuzz determinism readme)

# Tools, installed the way scripts/setup.sh does it: only what is missing.
packages=(clang clang-tidy libclang-rt-14-dev lld ccache ninja-build cmake python3)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "gates: installing ${missing[*]}" >&2
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
t_all=$SECONDS
stage_start=0
begin() {
  stage_start=$SECONDS
  printf '\n==================== gates: %s ====================\n' "$1"
  echo "load: $(cut -d' ' -f1-3 /proc/loadavg)  ($(nproc) cores)"
}
end() { echo "---- gates: $1 passed in $((SECONDS - stage_start)) s"; }
fail() {
  echo "---- gates: $1 FAILED after $((SECONDS - stage_start)) s" >&2
  exit 1
}

asan_dir=$root/build-gates-asan
stage_sanitize() {
  begin "sanitize: -Werror + ASan/UBSan build, every test under the sanitizers"
  # clang, not gcc: the same ASan/UBSan build costs gcc ~1.45x the CPU time (Eigen-heavy files: gcc's
  # UBSan instrumentation of the fixed-size matrix code), and a second compiler's -Werror catches what
  # gcc's does not; the determinism stage then compares two compilers' floating point, not one.
  # -O1 keeps the sanitized tests fast; -g1 (line tables) is enough for symbolised reports. bench/ is
  # not built here: it holds no test, and the release build (-Werror) and clang-tidy already cover it.
  mkdir -p "$asan_dir"
  cmake -S . -B "$asan_dir" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
    -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" -DCMAKE_C_FLAGS_DEBUG="-O1 -g1" \
    -DHEXSIM_SANITIZE=ON -DHEXSIM_WERROR=ON -DHEXSIM_BUILD_BENCH=OFF -DHEXSIM_PYTHON=OFF "${launcher[@]}" \
    > "$asan_dir/configure.log" 2>&1 || { cat "$asan_dir/configure.log"; fail sanitize; }
  cmake --build "$asan_dir" -j"$jobs" || fail "sanitize (build: a warning under -Werror or a compile error)"
  echo "build: $((SECONDS - stage_start)) s"
  # The long scenario tests (statistical gap trials, example projects, the browser) run 6-10x slower
  # under the sanitizers: a test that took longer than HEXSIM_SANITIZE_SKIP_S (default 1.5 s) in the
  # release ctest that scripts/test.sh just ran is left out here (listed below). Their code paths are
  # the ones the short tests exercise; the release run still runs them all. HEXSIM_SANITIZE_SKIP_S=0:
  # every test.
  local skip_regex
  # A fixture's setup test (FIXTURES_SETUP, e.g. bridge_peer_npm's npm ci, slow on a fresh clone) is
  # never left out: -E drops it without dropping the tests that require it, which then run without
  # their fixture (CI stop 40: bridge_peer_test failed under the sanitizers with node-mavlink absent).
  ctest --test-dir "$asan_dir" --show-only=json-v1 > "$asan_dir/tests.json" 2>/dev/null || echo '{}' > "$asan_dir/tests.json"
  skip_regex=$(python3 - "$root/build/Testing/Temporary/CTestCostData.txt" "${HEXSIM_SANITIZE_SKIP_S:-1.5}" "$asan_dir/tests.json" <<'EOF'
import json, re, sys
path, limit = sys.argv[1], float(sys.argv[2])
try:
    tests = json.load(open(sys.argv[3])).get("tests", [])
except (OSError, ValueError):
    tests = []
setups = {t["name"] for t in tests
          if any(p.get("name") == "FIXTURES_SETUP" for p in t.get("properties", []))}
slow = []
if limit > 0:
    try:
        for line in open(path):
            f = line.split()
            if (len(f) == 3 and re.fullmatch(r"[0-9.]+", f[2]) and float(f[2]) > limit
                    and f[0] not in setups):
                slow.append(f[0])
    except FileNotFoundError:
        pass
for name in sorted(slow):
    print("  not under the sanitizers (release > %.1f s): %s" % (limit, name), file=sys.stderr)
print("|".join("^" + re.escape(n) + "$" for n in slow))
EOF
)
  local -a exclude=()
  [ -z "$skip_regex" ] || exclude=(-E "$skip_regex")
  # Leaks inside third-party libraries (Mesa/llvmpipe) only: scripts/lsan.supp never names hexsim code.
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1:detect_stack_use_after_return=1 \
  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  LSAN_OPTIONS=suppressions=$root/scripts/lsan.supp:print_suppressions=0 \
    ctest --test-dir "$asan_dir" -j"$jobs" --output-on-failure --timeout 900 "${exclude[@]}" || fail sanitize
  end sanitize
}

tidy_dir=$root/build-gates-tidy
stage_tidy() {
  begin "clang-tidy: .clang-tidy over every project .cc, zero findings"
  mkdir -p "$tidy_dir"
  cmake -S . -B "$tidy_dir" -G Ninja -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
    -DCMAKE_BUILD_TYPE=Debug -DHEXSIM_BUILD_FUZZ=ON -DHEXSIM_BUILD_BENCH=ON -DHEXSIM_UNITY=OFF \
    > "$tidy_dir/configure.log" 2>&1 || { cat "$tidy_dir/configure.log"; fail tidy; }
  # The project's own sources only (not generated files in the build dir), each file once.
  local folders='(common|magnetics|vehicle|nav|control|logs|realdata|sim|bridge|identify|batch|gap|experiments|render|reports|envs|apps|python|fuzz|bench|test|examples)'
  python3 - "$tidy_dir/compile_commands.json" "$root" "$folders" "${HEXSIM_TIDY_FILES:-.}" > "$tidy_dir/files.txt" <<'EOF'
import json, re, sys
db, root, folders, only = sys.argv[1:5]
files = sorted({e["file"] for e in json.load(open(db))})
pat = re.compile(re.escape(root) + "/" + folders + "/")
print("\n".join(f for f in files if pat.match(f) and re.search(only, f)))
EOF
  echo "$(wc -l < "$tidy_dir/files.txt") files, -j$jobs"
  # Files whose front-end input (text, headers, comments, macros, flags), clang-tidy version and
  # .clang-tidy equal those of a clean run are not checked again (scripts/tidy_cache.py, like ctcache);
  # HEXSIM_TIDY_FULL=1 checks every file.
  local manifest=$root/.ci/tidy-clean.txt known=$root/.ci/tidy-clean.txt
  [ "${HEXSIM_TIDY_FULL:-0}" != 1 ] || known=/dev/null
  HEXSIM_GATES_JOBS=$jobs python3 scripts/tidy_cache.py select "$tidy_dir/compile_commands.json" "$root" \
    "$tidy_dir/files.txt" "$known" > "$tidy_dir/todo.txt"
  rm -rf "$tidy_dir/out" && mkdir -p "$tidy_dir/out"
  # shellcheck disable=SC2016
  # sh -c SCRIPT DIR FILE: $0 = the build dir, $1 = the file (xargs appends it).
  xargs -a "$tidy_dir/todo.txt" -r -P"$jobs" -n1 sh -c \
    'log="$0/out/$(echo "$1" | tr / _).log"; clang-tidy -p "$0" --quiet "$1" > "$log" 2>&1; echo "tidy-exit $?" >> "$log"' "$tidy_dir"
  local findings
  findings=$(cat /dev/null "$tidy_dir"/out/*.log 2>/dev/null | grep -E '^[^ ]+:[0-9]+:[0-9]+: (warning|error):' | sort -u || true)
  # The clean files' keys are kept even when others have findings (a file's key means: clean).
  [ -n "${HEXSIM_TIDY_FILES:-}" ] ||
    python3 scripts/tidy_cache.py update "$tidy_dir/files.txt.keys" "$manifest" "$root" "$tidy_dir/out"
  if [ -n "$findings" ]; then
    echo "$findings"
    echo "clang-tidy: $(echo "$findings" | wc -l) findings (full output: $tidy_dir/out/)" >&2
    fail tidy
  fi
  # A clang-tidy that died (a signal under memory pressure, a front-end crash) printed no finding
  # but checked nothing: the gate fails and names the file (its key is not recorded as clean).
  local died
  died=$(grep -L -x "tidy-exit 0" /dev/null "$tidy_dir"/out/*.log 2>/dev/null | grep -v '^/dev/null$' || true)
  if [ -n "$died" ]; then
    for log in $died; do echo "clang-tidy did not finish: $(basename "$log" .log) ($(tail -n 1 "$log"))" >&2; done
    fail tidy
  fi
  end tidy
}

stage_fuzz() {
  begin "fuzz: each target -runs=100000 (at most 240 s) -max_len=65536 from the seed corpus"
  HEXSIM_FUZZ_BUILD_DIR=$root/build-gates-fuzz HEXSIM_FUZZ_JOBS=$jobs bash fuzz/fuzz.sh -runs=100000 -max_total_time=240 || fail fuzz
  end fuzz
}

stage_determinism() {
  begin "determinism: release vs sanitizer build, same seed -> same log.csv"
  local release=$root/build/apps/hexsim sanitized=$asan_dir/apps/hexsim
  [ -x "$release" ] || { echo "no $release: run scripts/test.sh first" >&2; fail determinism; }
  [ -x "$sanitized" ] || { echo "no $sanitized: run the sanitize stage first" >&2; fail determinism; }
  local out
  out=$(mktemp -d)
  # Two runs: the truth-state loop (physics, powertrain, sensors, controller), and the paper's case
  # end to end (simulated turntable, ellipsoid + TLS fits, adaptive compensator, ESKF on the loop).
  local -a cases=(
    "truth|run square --vehicle default_hex --estimator truth --seed 3 --duration 20"
    "adaptive_eskf|run climb_cruise_square --vehicle paper_hex --world changchun --calibration adaptive --seed 3 --duration 40"
  )
  local c name args
  for c in "${cases[@]}"; do
    name=${c%%|*}
    read -r -a args <<< "${c#*|}"
    "$release" "${args[@]}" --out "$out/$name.release" > "$out/$name.release.txt" 2>&1 ||
      { cat "$out/$name.release.txt"; fail determinism; }
    ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    LSAN_OPTIONS=suppressions=$root/scripts/lsan.supp \
      "$sanitized" "${args[@]}" --out "$out/$name.sanitized" > "$out/$name.sanitized.txt" 2>&1 ||
      { cat "$out/$name.sanitized.txt"; fail determinism; }
    if ! cmp "$out/$name.release/log.csv" "$out/$name.sanitized/log.csv"; then
      diff <(head -c 2000000 "$out/$name.release/log.csv") <(head -c 2000000 "$out/$name.sanitized/log.csv") | head -20
      echo "$name: log.csv differs between the release and the sanitizer build (kept in $out)" >&2
      fail determinism
    fi
    echo "$name: log.csv identical ($(wc -l < "$out/$name.release/log.csv") lines, $(stat -c %s "$out/$name.release/log.csv") bytes)"
  done
  rm -rf "$out"
  end determinism
}

stage_readme() {
  begin "readme: README tables (Table 1, compare, log171) agree with a fresh run"
  [ -x "$root/build/apps/hexsim" ] || { echo "no $root/build/apps/hexsim: run scripts/test.sh first" >&2; fail readme; }
  bash scripts/readme_figures.sh --check || fail readme
  end readme
}

for s in "${stages[@]}"; do
  case $s in
    sanitize|tidy|fuzz|determinism|readme) "stage_$s" ;;
    *) echo "gates: unknown stage '$s' (sanitize tidy fuzz determinism readme)" >&2; exit 2 ;;
  esac
done
echo
echo "gates: all passed (${stages[*]}) in $((SECONDS - t_all)) s"
