#!/usr/bin/env bash
# Before/after pairs of `photosite bench night`, the way docs/benchmarks.md's "Latest runs" and the
# sessions' sections are measured: N pairs of runs of the two binaries, the order swapped every pair,
# each binary with its own checkout's preset folder, so that a load change hits both sides alike.
# Prints, per stage, each side's median ms and median ratio to its own run's OpenCV peer, and in
# how many pairs the after run took fewer ms and had the lower ratio (bench/pairs_summary.py).
#
# Usage: scripts/bench_pairs.sh BEFORE_BIN BEFORE_CHECKOUT AFTER_BIN AFTER_CHECKOUT N OUT_DIR [bench night options]
#   e.g. scripts/bench_pairs.sh /tmp/before/photosite /tmp/before build/photosite . 20 /tmp/pairs2
#        scripts/bench_pairs.sh ... 10 /tmp/pairs1 --threads 1 --cpu-clock
# OUT_DIR must not exist (the runs' outputs are kept there: a_K.txt, b_K.txt, csv/).
set -euo pipefail
if [ $# -lt 6 ]; then sed -n 8,11p "$0" >&2; exit 2; fi
ba=$1; da=$2; bb=$3; db=$4; n=$5; out=$6; shift 6
for b in "$ba" "$bb"; do [ -x "$b" ] || { echo "bench_pairs.sh: $b: not an executable" >&2; exit 2; }; done
for d in "$da" "$db"; do [ -d "$d/presets" ] || { echo "bench_pairs.sh: $d: no presets/ folder (a checkout?)" >&2; exit 2; }; done
[[ "$n" =~ ^[1-9][0-9]*$ ]] || { echo "bench_pairs.sh: N '$n' is not a positive integer" >&2; exit 2; }
[ ! -e "$out" ] || { echo "bench_pairs.sh: $out exists (not overwritten)" >&2; exit 2; }
mkdir -p "$out/csv"
run_a() { PHOTOSITE_PRESET_DIR="$da/presets" "$ba" bench night --repeats 9 --out-dir "$out/csv" "$@" > "$out/a_$i.txt" 2>&1; }
run_b() { PHOTOSITE_PRESET_DIR="$db/presets" "$bb" bench night --repeats 9 --out-dir "$out/csv" "$@" > "$out/b_$i.txt" 2>&1; }
# The order swaps every pair (before first in odd pairs, after first in even ones): on a shared
# machine the second run of a pair was measured slower than the first with the same binary on both
# sides (2026-11-29, docs/benchmarks.md "eleventh session"), which a fixed order would charge to one side.
for i in $(seq 1 "$n"); do
  if [ $((i % 2)) = 1 ]; then run_a "$@"; run_b "$@"; else run_b "$@"; run_a "$@"; fi
done
echo "load average after the runs: $(cut -d' ' -f1-3 /proc/loadavg)"
/usr/bin/python3 "$(dirname "$0")/../bench/pairs_summary.py" "$out"
