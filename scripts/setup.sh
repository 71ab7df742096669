#!/usr/bin/env bash
# Installs photosite's Debian 12 build and run dependencies and builds it (Release) into build/.
# Usage: scripts/setup.sh            (as root, or with sudo available)
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/lib.sh
# The image codecs: OpenEXR, libspng, libjpeg-turbo, libtiff (and libpng, libdeflate, zlib). OpenImageIO
# is for the tests (the reference the codecs are checked against) and its tools (oiiotool, a
# bench peer; idiff, scripts/bitcheck.sh); the library and the command do not link it.
PKGS=(build-essential cmake ninja-build pkg-config
      libopenexr-dev libimath-dev libspng-dev libjpeg-dev libtiff-dev libpng-dev libdeflate-dev zlib1g-dev libxxhash-dev
      libopenimageio-dev openimageio-tools libopencv-dev
      libvulkan-dev mesa-vulkan-drivers vulkan-validationlayers vulkan-tools glslang-tools
      libtomlplusplus-dev libcli11-dev libfmt-dev nlohmann-json3-dev
      libgtest-dev libbenchmark-dev python3-matplotlib python3-numpy
      python3-dev pybind11-dev python3-pybind11 python3-pytest python3-torch python3-skbuild python3-venv
      python3-sklearn python3-scipy python3-pil)
install_missing_packages "${PKGS[@]}"
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)"
