#!/usr/bin/env bash
# Runs on a lent GPU machine, from the repository root, over the bundle scripts/device_bundle.sh
# made (.dev/, plus .gl/: Debian's Vulkan loader and glvnd packages). It names the machine, runs the
# Vulkan tests on the real driver (under Khronos' validation layer) and the AVX-512 tests, then
# `bench night --backend vulkan` and `bench pipeline`. Everything goes to $OUT (log.txt, the CSVs).
# Locally (no $OUT) it runs the same on whatever driver the loader finds, into /tmp/device-out.
set -u
OUT=${OUT:-/tmp/device-out}
mkdir -p "$OUT"
exec > >(tee "$OUT/log.txt") 2>&1
step() { echo; echo "=== $* ($(date -u +%T))"; }
if [ -d .gl ] && ! ldconfig -p | grep -q 'libvulkan.so.1 '; then
  for f in .gl/*.deb; do dpkg -x "$f" /; done
  ldconfig
fi
ROOT=/opt/ps   # the path the test binary was built for (device_bundle.sh)
mkdir -p /opt; [ "$(readlink -f $ROOT)" = "$(pwd -P)" ] || ln -sfn "$(pwd -P)" $ROOT
cd $ROOT
# bench pipeline reads its frame from the source folder compiled in (/work/main/../shared).
[ -e /work/main ] || { mkdir -p /work && ln -s $ROOT /work/main; }
[ -e /work/shared ] || ln -s $ROOT/.dev/shared /work/shared
[ -e /opt/shared ] || ln -s $ROOT/.dev/shared /opt/shared   # /work/main/.. is /opt when /work/main links to /opt/ps
mkdir -p /tmp/psdev && xz -dc .dev/lib.tar.xz | tar -C /tmp/psdev -xf -
export LD_LIBRARY_PATH=/tmp/psdev/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
export VK_LAYER_PATH=/tmp/psdev/lib/layer VK_ADD_LAYER_PATH=/tmp/psdev/lib/layer
if [ -z "${VK_DRIVER_FILES:-}" ]; then
  for j in /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json /usr/share/vulkan/icd.d/nvidia_icd.json \
           /etc/vulkan/icd.d/nvidia_icd.json; do
    [ -f "$j" ] && { export VK_DRIVER_FILES=$j VK_ICD_FILENAMES=$j; break; }
  done
fi
[ -f /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json ] &&
  export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
export PHOTOSITE_PRESET_DIR=$ROOT/presets PHOTOSITE_DEVICE_STORE=/tmp/ps-store
P=.dev/bin/photosite
mkdir -p "$OUT/t2" "$OUT/t16"
CS=.dev/shared/data/cityscapes
IMG=$CS/leftImg8bit/aachen_000000_000019_leftImg8bit.png
LAB=$CS/gtFine/aachen_000000_000019_gtFine_labelIds.png
INS=$CS/gtFine/aachen_000000_000019_gtFine_instanceIds.png

make_manifest() {
  mkdir -p /tmp/bf && : > /tmp/bf/manifest
  for k in 1 2 3 4 5 6 7 8; do
    for f in $CS/leftImg8bit/*_leftImg8bit.png; do
      s=$(basename "$f" _leftImg8bit.png)
      ln -sf "$(pwd -P)/$f" /tmp/bf/${s}_$k.png
      ln -sf "$(pwd -P)/$CS/gtFine/${s}_gtFine_labelIds.png" /tmp/bf/${s}_${k}_labelIds.png
      ln -sf "$(pwd -P)/$CS/gtFine/${s}_gtFine_instanceIds.png" /tmp/bf/${s}_${k}_instanceIds.png
      echo "/tmp/bf/${s}_$k.png /tmp/bf/${s}_${k}_labelIds.png /tmp/bf/${s}_${k}_instanceIds.png" >> /tmp/bf/manifest
    done
  done
}
import_step() {
  step "imported host pages (the default where offered) against the staging slots alone (PHOTOSITE_VK_HOST_IMPORT=0): bench night --backend vulkan, 2 threads, alternating"
  for i in 1 2 3 4; do
    for m in 0 1; do
      echo "-- PHOTOSITE_VK_HOST_IMPORT=$m, pair $i"
      mkdir -p "/tmp/hi_$m$i"
      PHOTOSITE_VK_HOST_IMPORT=$m timeout 60 $P bench night --backend vulkan --image "$IMG" --labels "$LAB" --instances "$INS" \
        --repeats 9 --threads 2 --out-dir "/tmp/hi_$m$i" 2>&1 | grep -E '^(vulkan|whole chain|peer:)|imported host pages'
    done
  done
  for m in 0 1; do
    echo "-- bench pipeline, PHOTOSITE_VK_HOST_IMPORT=$m"
    mkdir -p "$OUT/import$m"
    PHOTOSITE_VK_HOST_IMPORT=$m timeout 60 $P bench pipeline --backend vulkan --repeats 5 --threads 2 --out-dir "$OUT/import$m" 2>&1 |
      grep -E 'wall|Sensor noise|RAW|Composition|device'
  done
  for m in 0 1; do
    rm -rf /tmp/bo
    echo "-- batch --backend vulkan --jobs 4, PHOTOSITE_VK_HOST_IMPORT=$m: $(PHOTOSITE_VK_HOST_IMPORT=$m timeout 120 $P batch --manifest /tmp/bf/manifest --out /tmp/bo --backend vulkan --jobs 4 2>&1 | tail -n 1)"
  done
}
# PHOTOSITE_DEVICE_ONLY=import: the machine and the import comparison alone (its bench night pairs,
# bench pipeline and batch --jobs 4 with and without imported host pages). import-batch: only
# alternating batch runs over the 40 frames, PAIRS (6) pairs each with --jobs in JOBS ("4 1"), the
# values of PHOTOSITE_VK_HOST_IMPORT in ORDER ("0 1"; "unset": batch's own choice); WITH_TESTS=1
# runs the Vulkan tests first.
if [ "${PHOTOSITE_DEVICE_ONLY:-}" = import ]; then
  step machine; $P version 2>&1
  make_manifest; import_step; step done; exit 0
fi
# benches: the machine, then bench night --backend vulkan at 2 and 16 threads and bench pipeline alone.
if [ "${PHOTOSITE_DEVICE_ONLY:-}" = benches ]; then
  step machine; $P version --backends 2>&1
  for t in 2 16; do
    step "bench night, CPU and Vulkan, $t threads"
    mkdir -p "$OUT/t$t"
    timeout 100 $P bench night --backend vulkan --image "$IMG" --labels "$LAB" --instances "$INS" \
      --repeats 9 --threads $t --out-dir "$OUT/t$t" 2>&1 | tail -n 40
  done
  step "bench pipeline"
  timeout 90 $P bench pipeline --backend vulkan --repeats 5 --threads 2 --out-dir "$OUT/t2" 2>&1 | tail -n 40
  step done; exit 0
fi
if [ "${PHOTOSITE_DEVICE_ONLY:-}" = import-batch ]; then
  step machine; $P version 2>&1
  if [ "${WITH_TESTS:-0}" = 1 ]; then
    step "Vulkan and AVX-512 tests"
    timeout 200 .dev/bin/photosite_gpu_tests --gtest_filter='Gpu.*:GpuCli.*:*Vulkan*:*Avx512*:FacadeWindows.Reciprocal*' > "$OUT/tests_staged.txt" 2>&1
    echo "tests exit: $?"
    grep -E '^\[  (FAILED|PASSED|SKIPPED) |tests ran|^\[gpu\] device' "$OUT/tests_staged.txt"
  fi
  make_manifest
  # ORDER="1 0" runs the import first in each pair (a check on the order's own effect).
  for jobs in ${JOBS:-4 1}; do
    step "batch --backend vulkan --jobs $jobs over 40 frames, PHOTOSITE_VK_HOST_IMPORT=${ORDER:-0 1} alternating"
    for i in $(seq 1 ${PAIRS:-6}); do
      for m in ${ORDER:-0 1}; do
        rm -rf /tmp/bo
        t0=$(date +%s%N)
        # "unset": batch's own choice (imported pages where offered)
        if [ "$m" = unset ]; then
          r=$(env -u PHOTOSITE_VK_HOST_IMPORT timeout 60 $P batch --manifest /tmp/bf/manifest --out /tmp/bo --backend vulkan --jobs $jobs 2>&1 | tail -n 1)
        else
          r=$(PHOTOSITE_VK_HOST_IMPORT=$m timeout 60 $P batch --manifest /tmp/bf/manifest --out /tmp/bo --backend vulkan --jobs $jobs 2>&1 | tail -n 1)
        fi
        echo "-- pair $i, PHOTOSITE_VK_HOST_IMPORT=$m: $(( ($(date +%s%N) - t0) / 1000000 )) ms wall: $r"
      done
    done
  done
  step done; exit 0
fi
step machine
nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.sm,clocks.mem --format=csv 2>&1 | head -3
lscpu | grep -E '^(Model name|CPU\(s\)|Thread|Core)' ; uname -r
echo "AVX-512: $(grep -o 'avx512[a-z_]*' /proc/cpuinfo | sort -u | tr '\n' ' ')"
echo "driver manifest: ${VK_DRIVER_FILES:-none}"
$P version 2>&1

T=.dev/bin/photosite_gpu_tests
FILTER='Gpu.*:GpuCli.*:*Vulkan*:*Avx512*:FacadeWindows.Reciprocal*'
step "Vulkan and AVX-512 tests (whole output: tests_staged.txt)"
timeout 200 $T --gtest_filter="$FILTER" > "$OUT/tests_staged.txt" 2>&1
echo "tests exit: $?"
grep -E '^\[  (FAILED|PASSED|SKIPPED) |tests ran|^\[gpu\] device' "$OUT/tests_staged.txt"
if [ "${PHOTOSITE_DEVICE_QUICK:-0}" != 1 ]; then
  step "the Vulkan tests again with direct (mapped) buffers, not the staged copies a discrete GPU gets by default"
  PHOTOSITE_VK_STAGING=0 timeout 120 $T --gtest_filter='Gpu.*:Batch.Vulkan*' > "$OUT/tests_direct.txt" 2>&1
  echo "tests exit: $?"
  grep -E '^\[  (FAILED|PASSED|SKIPPED) |tests ran' "$OUT/tests_direct.txt"
fi
if [ -x .dev/old/photosite_gpu_tests ]; then
  step "the previous test binary (.dev/old) on the demosaic tests (whole output: tests_old.txt)"
  timeout 100 .dev/old/photosite_gpu_tests --gtest_filter='Gpu.Demosaic*:Gpu.Mlri*:Gpu.CliDemosaic*' > "$OUT/tests_old.txt" 2>&1
  echo "tests exit: $?"
  grep -E '^\[  (FAILED|PASSED|SKIPPED) |tests ran' "$OUT/tests_old.txt"
  step "exit status of one trivial Vulkan test, with and without the validation layer"
  .dev/old/photosite_gpu_tests --gtest_brief=1 --gtest_filter=Gpu.BackendIsBuiltAndADeviceOpens > /dev/null 2>&1; echo "validation on: exit $?"
  PHOTOSITE_VK_VALIDATION=0 .dev/old/photosite_gpu_tests --gtest_brief=1 --gtest_filter=Gpu.BackendIsBuiltAndADeviceOpens > /dev/null 2>&1; echo "validation off: exit $?"
  $T --gtest_brief=1 --gtest_filter=Gpu.BackendIsBuiltAndADeviceOpens > /dev/null 2>&1; echo "new binary, validation on: exit $?"
fi

step "bench night, CPU and Vulkan, 2 threads"
timeout 100 $P bench night --backend vulkan --image "$IMG" --labels "$LAB" --instances "$INS" \
  --repeats 9 --threads 2 --out-dir "$OUT/t2" 2>&1 | tail -n 40
step "bench night, CPU and Vulkan, 16 threads"
timeout 70 $P bench night --backend vulkan --image "$IMG" --labels "$LAB" --instances "$INS" \
  --repeats 9 --threads 16 --out-dir "$OUT/t16" 2>&1 | tail -n 40
step "bench pipeline"
timeout 90 $P bench pipeline --backend vulkan --repeats 5 --threads 2 --out-dir "$OUT/t2" 2>&1 | tail -n 40
step "batch over 40 frames (the Cityscapes samples under 8 names each), CPU and Vulkan, every thread"
make_manifest
for args in "--backend cpu" "--backend vulkan" "--backend vulkan --jobs 4" \
            "--backend cpu --format png --layers sensor,labels" "--backend vulkan --format png --layers sensor,labels --jobs 4"; do
  rm -rf /tmp/bo
  echo "-- batch $args: $(timeout 120 $P batch --manifest /tmp/bf/manifest --out /tmp/bo $args 2>&1 | tail -n 1)"
done
import_step
if [ -x .dev/old/photosite ]; then
  step "the previous command (.dev/old/photosite) against this one: bench night --backend vulkan, 2 threads, alternating"
  for i in 1 2 3; do
    for b in old bin; do
      mkdir -p "/tmp/ab_$b$i"
      echo "-- .dev/$b/photosite, pair $i"
      timeout 60 .dev/$b/photosite bench night --backend vulkan --image "$IMG" --labels "$LAB" --instances "$INS" \
        --repeats 9 --threads 2 --out-dir "/tmp/ab_$b$i" 2>&1 | grep -E '^(vulkan|whole chain|peer:)'
    done
  done
  for b in old bin; do
    echo "-- .dev/$b/photosite bench pipeline"
    timeout 60 .dev/$b/photosite bench pipeline --backend vulkan --repeats 5 --threads 2 --out-dir /tmp 2>&1 | grep -E 'wall|Sensor noise|RAW'
  done
fi
# PHOTOSITE_DEVICE_QUICK=1: the staged path only (the mapped-buffer benches take minutes on a discrete GPU).
[ "${PHOTOSITE_DEVICE_QUICK:-0}" = 1 ] && { step done; exit 0; }
step "bench night and bench pipeline with mapped buffers (PHOTOSITE_VK_STAGING=0: no staging copies)"
mkdir -p "$OUT/direct"
PHOTOSITE_VK_STAGING=0 timeout 100 $P bench night --backend vulkan --image "$IMG" --labels "$LAB" --instances "$INS" \
  --repeats 9 --threads 2 --out-dir "$OUT/direct" 2>&1 | grep -E '^(vulkan|whole chain|peer:)'
PHOTOSITE_VK_STAGING=0 timeout 90 $P bench pipeline --backend vulkan --repeats 5 --threads 2 --out-dir "$OUT/direct" 2>&1 | tail -n 30
step done
