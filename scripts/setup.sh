#!/usr/bin/env bash
# Installs photosite's Debian 12 build and run dependencies and builds it (Release) into build/.
# Usage: scripts/setup.sh            (as root, or with sudo available)
set -euo pipefail
cd "$(dirname "$0")/.."
PKGS=(build-essential cmake ninja-build pkg-config
      libopenimageio-dev openimageio-tools libopenexr-dev libimath-dev libopencv-dev
      libvulkan-dev mesa-vulkan-drivers vulkan-validationlayers vulkan-tools glslang-tools
      libtomlplusplus-dev libcli11-dev libfmt-dev nlohmann-json3-dev
      libgtest-dev libbenchmark-dev python3-matplotlib python3-numpy)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)"
