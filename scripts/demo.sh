#!/usr/bin/env bash
# Installs the dependencies, builds (Release) and runs photosite's main job on the bundled sample.
# Outputs land in out/ (see README.md for what each file is).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
mkdir -p out
export PHOTOSITE_DEVICE_STORE="${PHOTOSITE_DEVICE_STORE:-$PWD/out/device-store}"
./build/photosite expose --radiance samples/night-chart.exr --preset onsemi-ar0331 \
  --exposure-s 0.02 --seed 1 --out out/chart.exr --preview out/chart.png --overwrite
echo "photosite: wrote out/chart.exr (camera output) and out/chart.png (preview)"
