#!/usr/bin/env bash
# Installs the dependencies, builds (Release) and runs photosite's main job on the bundled samples:
# the day-to-night translation of the bundled KITTI frame, and the sensor on the night test chart.
# Outputs land in out/ (see README.md for what each file is).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
mkdir -p out
export PHOTOSITE_DEVICE_STORE="${PHOTOSITE_DEVICE_STORE:-$PWD/out/device-store}"
./build/photosite demo --out out/night.exr --preview out/night.png --timings --overwrite
./build/photosite expose --radiance samples/night-chart.exr --preset onsemi-ar0331 \
  --exposure-s 0.02 --seed 1 --out out/chart.exr --preview out/chart.png --overwrite
echo "photosite: wrote out/night.exr, out/night.png, out/chart.exr, out/chart.png"
