#!/usr/bin/env bash
# Installs the dependencies, builds (Release) and runs the whole test suite under ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
# Vulkan tests run on Mesa's lavapipe (the CPU driver) unless a caller chose a driver.
lvp=$(ls /usr/share/vulkan/icd.d/lvp_icd.*.json 2>/dev/null | head -n 1 || true)
if [ -n "$lvp" ] && [ -z "${VK_DRIVER_FILES:-}${VK_ICD_FILENAMES:-}" ]; then
  export VK_DRIVER_FILES="$lvp" VK_ICD_FILENAMES="$lvp"
fi
cd build
ctest --output-on-failure -j"$(nproc)" --timeout 900
