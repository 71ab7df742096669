#!/usr/bin/env bash
# Makes .dev/ (ignored by git): what a lent GPU machine needs to run photosite's Vulkan path on
# its real driver. That machine is not Debian and has none of photosite's libraries, and
# photosite_tests links OpenImageIO and OpenCV's codecs (the codecs' references), whose closure is
# hundreds of MB. So this builds photosite_gpu_tests: the test files that exercise the Vulkan path
# and the AVX-512 kernels (no codec references), linked like photosite_tests without those two,
# with the paths the tests compile in pointed at /opt/ps (scripts/device_check.sh links the
# checkout there). The command and the test binary travel with the shared libraries they need
# (glibc and libstdc++ excepted: the machine's own are newer). bench batch's OpenCV imwrite peer
# (libphotosite_opencv_peers.so, with OpenCV's codecs behind it) stays behind.
# Usage, from the repository root after a Release build in build/:
#   scripts/device_bundle.sh            then run scripts/device_check.sh on the device machine
#   scripts/device_bundle.sh --keep-previous
#                                       the same, the previous bundle's command kept as .dev/old/photosite,
#                                       which device_check.sh then runs alternately with the new one
set -euo pipefail
cd "$(dirname "$0")/.."
B=build
[ -x "$B/photosite" ] && [ -f "$B/libphotosite_lib.a" ] || { echo "device_bundle: build first (build/photosite)" >&2; exit 2; }
if [ "${1:-}" = --keep-previous ]; then
  [ -x .dev/bin/photosite ] || { echo "device_bundle: --keep-previous: no previous bundle (.dev/bin/photosite)" >&2; exit 2; }
  mkdir -p .dev/old && cp .dev/bin/photosite .dev/old/photosite
elif [ -n "${1:-}" ]; then
  echo "device_bundle: unknown argument '$1' (--keep-previous or nothing)" >&2; exit 2
fi
[ -d .dev/old ] && mv .dev/old /tmp/device-bundle-old
rm -rf .dev && mkdir -p .dev/bin .dev/lib .dev/obj .dev/shared/data
[ -d /tmp/device-bundle-old ] && mv /tmp/device-bundle-old .dev/old   # a previous test binary kept to compare with
ROOT=/opt/ps
DEFS=(-DFMT_SHARED -DPHOTOSITE_HAVE_VULKAN=1 -DPHOTOSITE_VERSION=\"0.1.0\"
      -DPHOTOSITE_BIN=\"$ROOT/.dev/bin/photosite\" -DPHOTOSITE_PEAK_RSS_BIN=\"$ROOT/.dev/bin/peak_rss\"
      -DPHOTOSITE_PRESET_DIR=\"$ROOT/presets\" -DPHOTOSITE_SHARED_DIR=\"$ROOT/.dev/shared\"
      -DPHOTOSITE_SOURCE_DIR=\"$ROOT\")
FLAGS=(-I. -Ikernels -Iinclude -isystem /usr/include/opencv4 -isystem /usr/include/OpenEXR
       -isystem /usr/include/Imath -O3 -DNDEBUG -fopenmp -DTOML_HEADER_ONLY=0 -DTOML_SHARED_LIB=1
       -DGTEST_HAS_PTHREAD=1 -std=c++20)
SOURCES=(gpu_test batch_test demosaic_ri_test glare_test scene_metric_test test_util)
pids=()
for s in "${SOURCES[@]}"; do
  c++ "${DEFS[@]}" "${FLAGS[@]}" -c "tests/$s.cpp" -o ".dev/obj/$s.o" & pids+=($!)
  [ ${#pids[@]} -lt 2 ] || { wait "${pids[0]}"; pids=("${pids[@]:1}"); }
done
for p in "${pids[@]}"; do wait "$p"; done
L=/usr/lib/x86_64-linux-gnu
c++ -O3 -fopenmp -o .dev/bin/photosite_gpu_tests .dev/obj/*.o "$B/libphotosite_lib.a" \
  $L/libgtest.a $L/libgtest_main.a -ljpeg -ltiff -lspng -ltomlplusplus -ldeflate -lxxhash -lpng \
  -ldl -lfmt -lOpenEXR-3_1 -lImath-3_1 -lIlmThread-3_1 -lIex-3_1 -lopencv_imgproc -lopencv_core -lz -lpthread
rm -rf .dev/obj
cp "$B/photosite" "$B/peak_rss" .dev/bin/
# The shared libraries, but not glibc's own, libstdc++ or libgcc (the machine's are newer).
for exe in .dev/bin/photosite .dev/bin/photosite_gpu_tests; do
  ldd "$exe" | awk '/=> \//{print $3}'
done | sort -u | grep -Ev '/(libc|libm|libpthread|libdl|librt|libstdc\+\+|libgcc_s)\.so' |
  while read -r lib; do cp -L "$lib" .dev/lib/; done
# Khronos' validation layer (the Gpu tests run under it), with a manifest that names it beside itself.
mkdir -p .dev/lib/layer
cp -L /usr/lib/x86_64-linux-gnu/libVkLayer_khronos_validation.so .dev/lib/layer/
sed 's#"library_path": "libVkLayer_khronos_validation.so"#"library_path": "./libVkLayer_khronos_validation.so"#' \
  /usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json > .dev/lib/layer/VkLayer_khronos_validation.json
# Packed: the working tree that travels is limited to 64 MiB.
tar -C .dev -cf - lib | xz -T2 -6 > .dev/lib.tar.xz && rm -rf .dev/lib
# The shared data the Vulkan tests and the benches read (the Cityscapes samples).
for d in cityscapes; do
  [ -d ../shared/data/$d ] && cp -r ../shared/data/$d .dev/shared/data/
done
# Debian's Vulkan loader and glvnd, for a machine whose image has none (device_check.sh unpacks
# them there): downloaded once from Debian's archive into .gl/.
if ! ls .gl/libvulkan1_*.deb > /dev/null 2>&1; then
  mkdir -p .gl /tmp/amd64/partial
  o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
  apt-get $o update -qq && (cd .gl && apt-get $o download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
fi
du -sh .dev .dev/* >&2
