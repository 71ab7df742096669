#!/usr/bin/env bash
# Installs the dependencies, builds (Release) and runs the whole test suite under ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/lib.sh
scripts/setup.sh
# Vulkan tests run on Mesa's lavapipe (the CPU driver) unless a caller chose a driver.
use_lavapipe_unless_chosen
cd build
ctest --output-on-failure -j"$(nproc)" --timeout 900
