#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/, clang + ASan + UBSan) into build-fuzz/ and runs each for a
# bounded time on a seed corpus (the bundled presets, small label images, a real device map).
# Usage: scripts/fuzz.sh [seconds per target, default 30] [target...]
#   targets: preset labels device_map (default: all three)
# A crash, leak, sanitizer report, timeout (>10 s per input) or out-of-memory (>2 GB) fails the
# run and leaves the input in build-fuzz/artifacts/. Corpora grow in build-fuzz/corpus/.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/lib.sh
SECONDS_PER_TARGET=${1:-30}
shift || true
TARGETS=("$@")
[ ${#TARGETS[@]} -gt 0 ] || TARGETS=(preset labels device_map)
# The normal build does not need clang: the fuzzing tool chain is installed here only.
scripts/setup.sh
FUZZ_PKGS=(clang libclang-rt-14-dev libomp-dev)
install_missing_packages "${FUZZ_PKGS[@]}"
CC=clang CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DPHOTOSITE_FUZZ=ON -DPHOTOSITE_TESTS=OFF -DPHOTOSITE_BENCH=OFF -DPHOTOSITE_VULKAN=OFF >/dev/null
cmake --build build-fuzz -j"${JOBS:-$(nproc)}" --target "${TARGETS[@]/#/fuzz_}"

# ---- seed corpora ---------------------------------------------------------------------------
C=build-fuzz/corpus
mkdir -p "$C/preset" "$C/labels" "$C/device_map" build-fuzz/artifacts
# Presets: first byte picks the parser (0 camera, 1 lens, 2 scene).
for f in presets/cameras/*.toml; do { printf '\000'; cat "$f"; } > "$C/preset/seed-camera-$(basename "$f")"; done
for f in presets/lenses/*.toml; do { printf '\001'; cat "$f"; } > "$C/preset/seed-lens-$(basename "$f")"; done
for f in presets/scenes/*.toml; do { printf '\002'; cat "$f"; } > "$C/preset/seed-scene-$(basename "$f")"; done
# Labels: 3 header bytes (path/format, width, height), then a PNG (labelIds, trainIds, palette,
# 16-bit instance ids) or raw values.
python3 - "$C/labels" <<'PY'
import struct, sys, zlib
out = sys.argv[1]
def png(w, h, channels, bits, px):
    color = {1: 0, 3: 2}[channels]
    raw = b""
    for y in range(h):
        raw += b"\0" + b"".join(struct.pack(">H" if bits == 16 else "B", v) for v in px[y * w * channels:(y + 1) * w * channels])
    def chunk(t, d): return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, bits, color, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
w, h = 16, 8
ids = [23 if y < 3 else 11 if y < 5 else 7 for y in range(h) for x in range(w)]
ids[w * 6 + 4] = 26
train = [10 if v == 23 else 2 if v == 11 else 0 for v in ids]; train[0] = 255
pal = {23: (70, 130, 180), 11: (70, 70, 70), 7: (128, 64, 128), 26: (0, 0, 142)}
rgb = [c for v in ids for c in pal[v]]
inst = [26001 if v == 26 else v for v in ids]
seeds = {"labelids": bytes([1, w - 2, h - 2]) + png(w, h, 1, 8, ids),
         "trainids": bytes([1 + 3 * 2, w - 2, h - 2]) + png(w, h, 1, 8, train),
         "palette": bytes([1 + 3 * 3, w - 2, h - 2]) + png(w, h, 3, 8, rgb),
         "instances": bytes([2, w - 2, h - 2]) + png(w, h, 1, 16, inst),
         "raw": bytes([0, w - 2, h - 2]) + bytes(ids)}
for k, v in seeds.items():
    open(f"{out}/seed-{k}", "wb").write(v)
PY
# The same labelIds as a TIFF and as a JPEG (lossy, so the ids are approximate: it feeds the
# JPEG reader) and a 16-bit TIFF of the instance ids: the readers of core/io.cpp besides PNG's.
/usr/bin/python3 - "$C/labels" <<'PY'
import io, sys
from PIL import Image
out, w, h = sys.argv[1], 16, 8
ids = [23 if y < 3 else 11 if y < 5 else 7 for y in range(h) for x in range(w)]
im = Image.new("L", (w, h)); im.putdata(ids)
for fmt, name, kw in (("TIFF", "tiff", {"compression": "tiff_deflate"}), ("JPEG", "jpeg", {"quality": 95})):
    b = io.BytesIO(); im.save(b, fmt, **kw)
    open(f"{out}/seed-{name}", "wb").write(bytes([1, w - 2, h - 2]) + b.getvalue())
inst = Image.new("I;16", (w, h)); inst.putdata([26001 if v == 11 else v for v in ids])
b = io.BytesIO(); inst.save(b, "TIFF")
open(f"{out}/seed-instances-tiff", "wb").write(bytes([2, w - 2, h - 2]) + b.getvalue())
PY
# Device map: a real 8x4 map made by the normal build (scripts/setup.sh built build/photosite).
store=$(mktemp -d)
build/photosite flat --preset sony-imx174 --device-id dev --device-store "$store" --width 8 --height 4 \
  --photons 100 --wavelength-nm 525 --out "$store/flat.exr" >/dev/null
find "$store" -name '*.exr' ! -name flat.exr -exec cp {} "$C/device_map/seed-dev_8x4.exr" \;
rm -rf "$store"
[ -s "$C/device_map/seed-dev_8x4.exr" ] || { echo "fuzz: could not make the device-map seed"; exit 1; }

# ---- run --------------------------------------------------------------------------------------
# Leaks inside third-party libraries (each explained in the file) are suppressed, as in
# scripts/sanitize.sh; every other leak is a finding.
export LSAN_OPTIONS="suppressions=$(pwd)/scripts/lsan.supp:print_suppressions=0"
for t in "${TARGETS[@]}"; do
  echo "== fuzz_$t for ${SECONDS_PER_TARGET} s"
  rc=0
  ./build-fuzz/fuzz/fuzz_$t "$C/$t" -max_total_time="$SECONDS_PER_TARGET" -timeout=10 -rss_limit_mb=2048 \
    -max_len=65536 -print_final_stats=1 -artifact_prefix=build-fuzz/artifacts/$t- \
    > "build-fuzz/fuzz_$t.log" 2>&1 || rc=$?
  grep -E "^(#[0-9]+ +(INITED|DONE)|Done |stat::number_of_executed_units|stat::peak_rss_mb|==[0-9]+==ERROR|SUMMARY)" \
    "build-fuzz/fuzz_$t.log" || true
  [ "$rc" -eq 0 ] || { echo "fuzz_$t FAILED (exit $rc): see build-fuzz/fuzz_$t.log and build-fuzz/artifacts/"; exit 1; }
done
echo "fuzz: all targets ran clean"
