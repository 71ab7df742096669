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

// div_rn(a, b) and sqrt_rn(x): the float quotient and square root rounded to nearest, as C++'s
// float division and std::sqrt give them (IEEE 754). Vulkan lets a 32-bit OpFDiv be 2.5 ULP off and
// sqrt inherit the error of 1/inversesqrt ("Precision and Operation of SPIR-V Instructions" in the
// Vulkan specification), and GPU drivers use those latitudes: on an NVIDIA H200 (driver
// 580.159.04, 2026-11-30, scripts/device_check.sh) the MLRI and LMMSE demosaic kernels, the ones
// that divide, differed from the CPU, and the normal Poisson sampler drew 1 count less at one pixel
// of the test's (a square root). So GLSL takes the driver's value and settles it exactly, with
// arithmetic Vulkan must do exactly. For m = |q| and the true quotient A/B (A = |a|, B = |b|), the
// residual r = A − m·B is exact in double (m·B has 48 significant bits, and r is a multiple of its
// last bit within a few ulps of m·B of A), and m is the correctly rounded quotient iff r lies
// within half the gap to m's neighbour on r's side, times B (exact: the gap is a power of two);
// the square root likewise with r = x − s² and the midpoint's square (s ± h)² = s² ± h·(2s ± h).
// The quotient or root of floats is never itself a midpoint (an odd 25-bit M would need M·B, or M²,
// to be a 24-bit significand times a power of two), so no tie arises. Each step moves one float;
// the first value is the driver's own float division or square root, within 3 ulps of the
// correctly rounded result for a 2.5-ulp division and within 5 for a square root inherited from
// 1/inversesqrt (2 + 2.5 ulps, rounded), so 6 steps are enough. Zero, infinite and NaN operands,
// and results that overflow or underflow to 0, keep the first value.
#ifdef __cplusplus
inline float div_rn(float a, float b) { return a / b; }
inline float sqrt_rn(float x) { return std::sqrt(x); }
#else
float next_up_magnitude(float m) { return uintBitsToFloat(floatBitsToUint(m) + 1u); }
float next_down_magnitude(float m) { return uintBitsToFloat(floatBitsToUint(m) - 1u); }
// The settling steps from a first value q (div_rn's, or one moved off on purpose by the rounding
// test's kernel, rounding.comp).
float div_rn_settle(float a, float b, float q) {
  if (q == 0.0 || isinf(q) || isnan(q) || isinf(a) || isinf(b)) return q;
  const double A = abs(double(a)), B = abs(double(b));
  float m = abs(q);
  for (int k = 0; k < 6; ++k) {
    precise double r = A - double(m) * B;
    if (r >= 0.0lf) {
      precise double half_gap_b = double(next_up_magnitude(m) - m) * 0.5lf * B;
      if (r < half_gap_b) break;
      m = next_up_magnitude(m);
    } else {
      precise double half_gap_b = double(m - next_down_magnitude(m)) * 0.5lf * B;
      if (-r < half_gap_b) break;
      m = next_down_magnitude(m);
    }
  }
  return (a < 0.0) != (b < 0.0) ? -m : m;
}
float div_rn(float a, float b) { return div_rn_settle(a, b, a / b); }
float sqrt_rn_settle(float x, float s) {
  if (!(x > 0.0) || isinf(x) || s == 0.0 || isinf(s) || isnan(s)) return s;
  const double X = double(x);
  for (int k = 0; k < 6; ++k) {
    precise double r = X - double(s) * double(s);
    if (r >= 0.0lf) {
      precise double h = double(next_up_magnitude(s) - s) * 0.5lf;
      precise double bound = h * (2.0lf * double(s) + h);
      if (r < bound) break;
      s = next_up_magnitude(s);
    } else {
      precise double h = double(s - next_down_magnitude(s)) * 0.5lf;
      precise double bound = h * (2.0lf * double(s) - h);
      if (-r < bound) break;
      s = next_down_magnitude(s);
    }
  }
  return s;
}
float sqrt_rn(float x) { return sqrt_rn_settle(x, sqrt(x)); }
#endif
#endif
