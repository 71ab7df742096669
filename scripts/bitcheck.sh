#!/usr/bin/env bash
# Same bits? Runs `photosite night --backend cpu --compression none` on the Cityscapes frames
# aachen_000000/1/3_000019 (with instance ids) with two binaries, each with its own checkout's preset
# folder and its own device store, and compares every channel of every pair of EXRs exactly
# (OpenImageIO's idiff: any pixel of any channel that differs fails; the headers' provenance
# strings are not compared). How docs/benchmarks.md's "every EXR channel is <before>'s" is checked;
# run it plain, with OMP_NUM_THREADS=1 in the environment, and with `--poisson cornish-fisher --seed 5`.
#
# Usage: scripts/bitcheck.sh BEFORE_BIN BEFORE_CHECKOUT AFTER_BIN AFTER_CHECKOUT OUT_DIR [night options]
# The frames come from $PHOTOSITE_CITYSCAPES, else AFTER_CHECKOUT/../shared/data/cityscapes.
# OUT_DIR must not exist. Exit 0: every channel equal; 1: a difference (idiff's report printed); 2: bad use.
set -uo pipefail
if [ $# -lt 5 ]; then sed -n 9,11p "$0" >&2; exit 2; fi
ba=$1; da=$2; bb=$3; db=$4; out=$5; shift 5
C=${PHOTOSITE_CITYSCAPES:-$db/../shared/data/cityscapes}
for b in "$ba" "$bb"; do [ -x "$b" ] || { echo "bitcheck.sh: $b: not an executable" >&2; exit 2; }; done
for d in "$da" "$db"; do [ -d "$d/presets" ] || { echo "bitcheck.sh: $d: no presets/ folder (a checkout?)" >&2; exit 2; }; done
[ -d "$C/leftImg8bit" ] || { echo "bitcheck.sh: $C: no Cityscapes frames (set PHOTOSITE_CITYSCAPES)" >&2; exit 2; }
command -v idiff > /dev/null || { echo "bitcheck.sh: idiff (openimageio-tools) not found" >&2; exit 2; }
[ ! -e "$out" ] || { echo "bitcheck.sh: $out exists (not overwritten)" >&2; exit 2; }
mkdir -p "$out"
rc=0
for f in 000000 000001 000003; do
  for side in a b; do
    if [ $side = a ]; then bin=$ba; src=$da; else bin=$bb; src=$db; fi
    if ! PHOTOSITE_PRESET_DIR="$src/presets" PHOTOSITE_DEVICE_STORE="$out/store_$side" "$bin" night \
        --image "$C/leftImg8bit/aachen_${f}_000019_leftImg8bit.png" \
        --labels "$C/gtFine/aachen_${f}_000019_gtFine_labelIds.png" \
        --instances "$C/gtFine/aachen_${f}_000019_gtFine_instanceIds.png" \
        --out "$out/${f}_$side.exr" --backend cpu --compression none "$@" > "$out/${f}_$side.log" 2>&1; then
      echo "bitcheck.sh: $bin failed on aachen_${f}:"; cat "$out/${f}_$side.log"; exit 1
    fi
  done
  # One comparison: its report kept in the .diff file, printed when the frames differ.
  if ! idiff -a -fail 0 -failpercent 0 -warn 0 "$out/${f}_a.exr" "$out/${f}_b.exr" > "$out/${f}.diff" 2>&1; then
    echo "aachen_${f}: channels differ"; tail -20 "$out/${f}.diff"; rc=1
  fi
done
[ $rc = 0 ] && echo "bitcheck: PASS (every channel of 3 frames equal)" || echo "bitcheck: FAIL"
exit $rc
