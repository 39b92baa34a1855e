#!/usr/bin/env bash
# Cuts the committed seed corpus from the shared real log (run from anywhere; rewrites the seeds).
#   corpus/dataflash/head_16k.bin     the first 16 KiB: every FMT (the first 6.4 KB), parameters
#   corpus/dataflash/fmt_mid.bin      the FMT block + 4 KiB from mid-flight (a garbage join between)
#   corpus/dataflash/fmt_end.bin      the FMT block + the last 4 KiB (ends at the real end of file)
# Seeds are kept small so that each execution is fast (libFuzzer still grows inputs to -max_len).
#   corpus/flightlog_csv/imported.csv the header and first 12 rows of `hexsim import` of that log
#   corpus/flightlog_csv/small.csv    a hand-written sim-style log with empty cells
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
log=${1:-$here/../data/real/ardupilot_copter_log171.bin}
out=$here/corpus/dataflash
mkdir -p "$out"
cut() { dd if="$log" iflag=skip_bytes,count_bytes skip="$1" count="$2" status=none; }
size=$(stat -c %s "$log")
rm -f "$out"/*.bin
cut 0 16384 > "$out/head_16k.bin"
{ cut 0 7000; cut 1500000 4096; } > "$out/fmt_mid.bin"
{ cut 0 7000; cut $((size - 4096)) 4096; } > "$out/fmt_end.bin"
du -cb "$here/corpus"/*/* | tail -1
