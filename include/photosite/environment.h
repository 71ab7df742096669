// Every environment variable photosite reads, read in one place (core/environment.cpp): no other
// file of the library calls getenv. The table is the documentation:
//
//   PHOTOSITE_DATA_DIR            the data folder (holding presets/); see data_dir()
//   PHOTOSITE_PRESET_DIR          the preset folder itself (cameras/, lenses/, scenes/)
//   PHOTOSITE_DEVICE_STORE        where fixed-pattern maps of simulated devices are kept
//   XDG_DATA_HOME, HOME           the device store's default (XDG base directory spec)
//   PHOTOSITE_MAX_PIXELS          the largest frame accepted, in pixels (default 2^28)
//   PHOTOSITE_VK_VALIDATION       1: Vulkan validation layer on, every message recorded
//   PHOTOSITE_VK_SYNC_VALIDATION  0: without synchronization validation (when validation is on)
//   PHOTOSITE_VK_STAGING          1|0: force staged copies or mapped buffers
//   PHOTOSITE_VK_HOST_IMPORT      0|1: staged copies never / always import the caller's pages (gpu/context.h)
//   PHOTOSITE_SAMPLE_DIR          the bundled sample images (the command's `night` default input)
//   PHOTOSITE_SCALAR_LIGHTS       1: the light map's street light and low beam take their scalar
//                                 paths on an AVX2 machine (read once; to check both give the same bits)
//   PHOTOSITE_MAX_ISA             scalar|avx2|avx512: the widest vector level the CPU paths dispatched
//                                 on core/isa_detail.h take (read once; unset: the CPU's own). Not
//                                 capped: the target_clones functions (see isa_detail.h). Another
//                                 value: a message naming the variable, exit status 2
//
// The Vulkan loader's own variables (VK_DRIVER_FILES, VK_ICD_FILENAMES) are read by the loader;
// OpenMP's (OMP_NUM_THREADS, ...) by libgomp, whose team size check_openmp_threads() bounds.
#pragma once
#include <optional>
#include <string>

namespace photosite::env {

enum class Var {
  DataDir,
  PresetDir,
  DeviceStore,
  XdgDataHome,
  Home,
  MaxPixels,
  ExrThreads,
  VkValidation,
  VkSyncValidation,
  VkStaging,
  VkHostImport,
  SampleDir,
  ScalarLights,
  MaxIsa,
  VkDriverFiles,   // the Vulkan loader's own (read here only to name them in a message)
  VkIcdFilenames,
};

const char* name(Var v);                 // "PHOTOSITE_DATA_DIR", ...
std::optional<std::string> get(Var v);   // the value; nullopt when unset or empty

}  // namespace photosite::env

namespace photosite {

// The folder of photosite's data (presets/ and, in a source tree, samples/), first found of:
//   1. $PHOTOSITE_DATA_DIR;
//   2. <dir>/../share/photosite or <dir>/../../share/photosite, where <dir> holds the library
//      itself (libphotosite.so, or the program it is linked into; found with dladdr), so an
//      installed tree finds its presets wherever it was moved;
//   3. the same, relative to the running program (/proc/self/exe);
//   4. the source tree this library was built from.
// The first three count only where a presets/ folder exists there.
std::string data_dir();

// The most OpenMP threads photosite runs a parallel region on. libgomp puts each new thread's
// start record on the stack of the thread that opens the region (gomp_team_start's alloca, about
// 100 bytes a thread), so OMP_NUM_THREADS=100000 overflowed the 8 MiB main stack: SIGSEGV in
// GOMP_parallel at the first parallel loop (20000 ran; thirty-fourth session). 4096 is 0.4 MiB
// of that stack and above the hardware threads of any one machine sold (a two-socket AMD EPYC
// 9965 has 768), where more threads only share the same cores.
inline constexpr int kMaxOpenmpThreads = 4096;
// Bad input (exit status 2) naming OMP_NUM_THREADS when OpenMP would open a team of more than
// kMaxOpenmpThreads threads (omp_get_max_threads(): the variable's first value). The command
// checks it before any work, the Python module when it is imported.
void check_openmp_threads();

}  // namespace photosite
