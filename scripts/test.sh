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
cd ..
# The Python module (build/python/photosite) under Debian's python3 and pytest; exit status 5
# ("no tests collected") means the module's tests are missing, which is a failure too.
if [ -d build/python/photosite ]; then
  status=0
  PYTHONPATH=build/python /usr/bin/python3 -m pytest -q tests/python || status=$?
  if [ "$status" -eq 5 ]; then echo "pytest collected no tests in tests/python" >&2; exit 1; fi
  exit "$status"
fi
