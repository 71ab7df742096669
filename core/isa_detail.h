// The machine's x86 vector instruction set, detected once: the one check the CPU code paths with
// AVX2 and AVX-512 variants dispatch on (sensor/, scene/, `photosite version --backends`). Every
// variant computes the same IEEE operations per lane in the same order, so the level chooses
// speed only, never a result.
#pragma once

namespace photosite::detail {

// 0 the scalar (SSE2 baseline) code, 1 AVX2 (with FMA), 2 AVX-512; each level includes the one below.
enum class Isa : int { scalar = 0, avx2 = 1, avx512 = 2 };

// The AVX-512 level is what the library's AVX-512 functions name in their target attributes,
// all of it: F, VL, BW and DQ (sensor/demosaic_mlri.cpp's pragma names the four; scene/street.cpp's
// "avx2,avx512f,avx512vl"; the others "avx512f"). Every AVX-512 CPU from Skylake-SP (2017) on has
// the four; Knights Landing/Mill (F, CD, ER, PF only) takes the AVX2 paths, which give the same
// bits. Off x86-64 GCC/Clang: scalar.
// $PHOTOSITE_MAX_ISA (scalar, avx2 or avx512; environment.h) caps the level, read once with the
// CPU's features (core/isa.cpp): to measure the AVX2 or scalar paths on an AVX-512 machine, or to
// check that every level gives the same bits. A value not among the three is reported on stderr,
// naming the variable, and the process exits with status 2 (the level is first asked for from
// static initialisers, where an exception could not reach the command's handler).
// Not capped by it: the functions with GCC's target_clones (PHOTOSITE_TARGET_CLONES below, and
// the AVX2-only clones of sensor/demosaic.cpp, scene/geometry.cpp and scene/darken.cpp), whose
// clone is chosen by the CPU's own features when the library is loaded, before any code of ours
// runs. Their clones do the same IEEE operations, so the cap changes no bits there, but they keep
// their AVX-512 speed under PHOTOSITE_MAX_ISA=avx2; configure with -DPHOTOSITE_CLONES_MAX_AVX2=ON
// (CMakeLists.txt) to build them without the AVX-512 clone, for a measurement of the AVX2 paths.
Isa machine_isa();
// The vector clones of the loops the compiler vectorises (see machine_isa above).
#if defined(PHOTOSITE_CLONES_MAX_AVX2)
#define PHOTOSITE_TARGET_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define PHOTOSITE_TARGET_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#endif

// The level as the paths' int caps count it (0 scalar, 1 AVX2, 2 AVX-512).
inline int machine_isa_level() { return static_cast<int>(machine_isa()); }
inline bool have_avx2() { return machine_isa() >= Isa::avx2; }
inline bool have_avx512() { return machine_isa() >= Isa::avx512; }

}  // namespace photosite::detail
