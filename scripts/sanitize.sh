#!/usr/bin/env bash
# Builds photosite with AddressSanitizer + UndefinedBehaviorSanitizer (PHOTOSITE_SANITIZE) into
# build-asan/ and runs the whole test suite under ctest. Any ASan report, leak or UBSan finding
# (float-cast-overflow included: CMakeLists.txt names it) fails the run (UBSan is built with
# -fno-sanitize-recover). docs/robustness.md has the results.
# Usage: scripts/sanitize.sh [ctest args...]     e.g. scripts/sanitize.sh -R 'BadInput'
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/lib.sh
scripts/setup.sh
JOBS=${JOBS:-$(nproc)}
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPHOTOSITE_SANITIZE=ON \
      -DPHOTOSITE_BENCH=OFF
cmake --build build-asan -j"$JOBS"
# Vulkan tests run on Mesa's lavapipe unless a caller chose a driver (as scripts/test.sh).
use_lavapipe_unless_chosen
here=$(pwd)
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=0:halt_on_error=1:detect_stack_use_after_return=1:strict_string_checks=1:check_initialization_order=1"
export LSAN_OPTIONS="suppressions=$here/scripts/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# Large frames under ASan are several times slower; the suite's own timeouts stay generous.
cd build-asan
ctest --output-on-failure -j"$JOBS" --timeout 3600 "$@"
