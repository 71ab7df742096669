// The machine's x86 vector instruction set, detected once: the one check the CPU code paths with
// AVX2 and AVX-512 variants dispatch on (sensor/, scene/, `photosite version --backends`). Every
// variant computes the same IEEE operations per lane in the same order, so the level chooses
// speed only, never a result.
#pragma once

namespace photosite::detail {

// 0 the scalar (SSE2 baseline) code, 1 AVX2, 2 AVX-512; each level includes the one below.
enum class Isa : int { scalar = 0, avx2 = 1, avx512 = 2 };

// The AVX-512 level is what the library's AVX-512 functions name in their target attributes,
// all of it: F, VL, BW and DQ (sensor/demosaic_mlri.cpp's pragma names the four; scene/street.cpp's
// "avx2,avx512f,avx512vl"; the others "avx512f"). Every AVX-512 CPU from Skylake-SP (2017) on has
// the four; Knights Landing/Mill (F, CD, ER, PF only) takes the AVX2 paths, which give the same
// bits. Off x86-64 GCC/Clang: scalar.
inline Isa machine_isa() {
#if defined(__x86_64__) && defined(__GNUC__)
  static const Isa isa = [] {
    __builtin_cpu_init();  // may run from another file's static initializer, before libgcc's
    if (!__builtin_cpu_supports("avx2")) return Isa::scalar;
    const bool avx512 = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
                        __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq");
    return avx512 ? Isa::avx512 : Isa::avx2;
  }();
  return isa;
#else
  return Isa::scalar;
#endif
}
// The level as the paths' int caps count it (0 scalar, 1 AVX2, 2 AVX-512).
inline int machine_isa_level() { return static_cast<int>(machine_isa()); }
inline bool have_avx2() { return machine_isa() >= Isa::avx2; }
inline bool have_avx512() { return machine_isa() >= Isa::avx512; }

}  // namespace photosite::detail
