// The prelude of the C++/GLSL common subset. The files of kernels/common that hold per-pixel
// maths (fastmath.glsl, philox_round.glsl, cornish_fisher.glsl, ptrs.glsl, sensor_pixel.glsl,
// darken.glsl, glare.glsl) are written once, in the subset of the two languages they share, and
// compiled both into the Vulkan kernels (glslang) and into the C++ library (through the private
// headers core/shader_subset.h, core/rng_detail.h, sensor/poisson_detail.h, sensor/pixel_detail.h,
// scene/darken_detail.h, sensor/glare_detail.h), so the CPU and Vulkan paths run the same float
// operations in the same order and give the same bits.
//
// The subset: float, double, int, uint, bool, uvec2, uvec4 (members .x .y .z .w and the
// constructor with all components), structs filled member by member, functional casts
// (float(i), uint(f), double(f)), floor, sqrt, abs, min, max, clamp (same argument types),
// the ternary, for loops, float literals with the f suffix, double literals as double(0.5).
// What differs, defined here for C++ (GLSL has them built in):
//   precise          GLSL's no-contraction qualifier; empty in C++, which is compiled with
//                    -ffp-contract=off (no FMA contraction, no reassociation) for the same reason
//   PS_FN            `inline` in C++, empty in GLSL
//   uintBitsToFloat, floatBitsToUint   the bit casts (std::bit_cast in C++)
//   umulExtended(a, b, hi, lo)         the 32x32 -> 64-bit product's halves (out parameters)
// C++ includes this file (and the others) inside namespace photosite::shader, after <algorithm>,
// <bit>, <cmath> and <cstdint>; `precise` and PS_FN are macros there, which
// common/prelude_end.glsl removes again. The macros are defined outside the include guard, so
// every block of shared files is framed by prelude.glsl ... prelude_end.glsl.
#ifdef __cplusplus
#define precise
#define PS_FN inline
#else
#define PS_FN
#endif

#ifndef PHOTOSITE_PRELUDE_GLSL
#define PHOTOSITE_PRELUDE_GLSL
#ifdef __cplusplus
using uint = uint32_t;
// The constructor with all components is declared, not left to C++20's parenthesized
// aggregate initialization, which clang before 16 lacks (the fuzz build, scripts/fuzz.sh).
struct uvec2 {
  uint x, y;
  uvec2() = default;
  constexpr uvec2(uint x_, uint y_) : x(x_), y(y_) {}
};
struct uvec4 {
  uint x, y, z, w;
  uvec4() = default;
  constexpr uvec4(uint x_, uint y_, uint z_, uint w_) : x(x_), y(y_), z(z_), w(w_) {}
};
inline float uintBitsToFloat(uint u) { return std::bit_cast<float>(u); }
inline uint floatBitsToUint(float f) { return std::bit_cast<uint>(f); }
inline void umulExtended(uint a, uint b, uint& hi, uint& lo) {
  const uint64_t p = static_cast<uint64_t>(a) * b;
  hi = static_cast<uint>(p >> 32);
  lo = static_cast<uint>(p);
}
using std::abs;
using std::clamp;
using std::floor;
using std::max;
using std::min;
using std::sqrt;
#endif
#endif
