// Working-resolution images and lane-marking segmentation (stage 2).
#include <algorithm>
#include <array>
#include <bit>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <omp.h>
#include <vector>
#include <opencv2/imgproc.hpp>
#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "photosite/scene/night.h"
#include "photosite/sensor/isp.h"
#include "core/isa_detail.h"
#include "photosite/error.h"
#include "scene/lanes_detail.h"
#include "scene/runs_detail.h"
#include "scene/srgb_detail.h"

namespace photosite::scene {

namespace {
// x^a for a = 1/2.4 (the double srgb_encode raises to) and x = 2^e·m (m in [1, 2)) a float in
// (0.0031308, 1): x^a = (2^e)^a · m0^a · (1 + t)^a with m0 = 1 + k/1024 the mantissa's first 10
// bits and t = (m − m0)/m0 in [0, 2^-10); (2^e)^a and m0^a from std::pow once (tables), (1 + t)^a
// by its binomial series to t^4 (the next term is below 0.03·2^-50 ≈ 3e-17). Relative error: the
// tables' roundings (std::pow: < 1 ulp each), the series' and the products' (a few ulp), under 1e-15.
struct PowTables {
  double two_e[16];  // (2^e)^a for e = -9 .. 0 (and 0 beyond: srgb_encode_block_avx512 reads 16)
  double m0a[1024], inv_m0[1024];
  double c1, c2, c3, c4;  // binomial coefficients C(a, n)
  // srgb_encode_block_avx512's: m0 = 1 + j/16 (the mantissa's first 4 bits), the series to t^8.
  double m0a16[16], inv_m016[16];
  double c5, c6, c7, c8;
  double c9, c10, c11;  // srgb_encode_block_avx2's series goes to t^11
};
const PowTables& pow_tables() {
  static const PowTables t = [] {
    PowTables p;
    const double a = 1.0 / 2.4;
    for (int e = -9; e <= 0; ++e) p.two_e[e + 9] = std::pow(std::ldexp(1.0, e), a);
    for (int k = 0; k < 1024; ++k) {
      const double m0 = 1.0 + k / 1024.0;
      p.m0a[k] = std::pow(m0, a);
      p.inv_m0[k] = 1.0 / m0;
    }
    p.c1 = a;
    p.c2 = p.c1 * (a - 1) / 2;
    p.c3 = p.c2 * (a - 2) / 3;
    p.c4 = p.c3 * (a - 3) / 4;
    for (int e = 1; e < 7; ++e) p.two_e[9 + e] = 0;
    for (int j = 0; j < 16; ++j) {
      const double m0 = 1.0 + j / 16.0;
      p.m0a16[j] = std::pow(m0, a);
      p.inv_m016[j] = 1.0 / m0;
    }
    p.c5 = p.c4 * (a - 4) / 5;
    p.c6 = p.c5 * (a - 5) / 6;
    p.c7 = p.c6 * (a - 6) / 7;
    p.c8 = p.c7 * (a - 7) / 8;
    p.c9 = p.c8 * (a - 8) / 9;
    p.c10 = p.c9 * (a - 9) / 10;
    p.c11 = p.c10 * (a - 10) / 11;
    return p;
  }();
  return t;
}

// The encode's float of n values, computed from the fast x^a where that decides it:
// y = 1.055·x^a − 0.055 differs from srgb_encode's own double by at most 1.055·(its x^a error +
// std::pow's < 1 ulp) plus two roundings — below 1e-13·y even where the subtraction cancels
// (y ≥ 0.04 at the toe, 1.055·x^a ≤ 2.4·y there) — so where y lies farther than 1e-12·y from both
// midpoints to the neighbouring floats, both round to the same float. Elsewhere (the toe, white,
// NaN, and about one value in 30 000 near a midpoint) `exact` is set and the caller takes the
// exact expression.
void srgb_encode_block(const float* v, int n, float* out, int32_t* exact) {
  const PowTables& T = pow_tables();
  for (int i = 0; i < n; ++i) {
    const float xf = v[i];
    // Values past the toe and below white (NaN fails both); 0.0031308f > 0.0031308, so no toe
    // value passes.
    const bool fast = xf > 0.0031308f && xf < 1.f;
    exact[i] = 1;
    if (!fast) continue;
    const uint32_t bits = std::bit_cast<uint32_t>(xf);
    const int e = static_cast<int>(bits >> 23) - 127;  // in [-9, -1]
    const int mant = static_cast<int>(bits & 0x7fffffu);
    const int k = mant >> 13;
    const double m = 1.0 + mant * 0x1p-23, m0 = 1.0 + k * 0x1p-10;
    const double t = (m - m0) * T.inv_m0[k];
    const double s = 1.0 + t * (T.c1 + t * (T.c2 + t * (T.c3 + t * T.c4)));
    const double y = 1.055 * (T.two_e[e + 9] * T.m0a[k] * s) - 0.055;
    const float f = static_cast<float>(y);
    const uint32_t fb = std::bit_cast<uint32_t>(f);
    const double lo = 0.5 * (static_cast<double>(std::bit_cast<float>(fb - 1)) + f);
    const double hi = 0.5 * (static_cast<double>(std::bit_cast<float>(fb + 1)) + f);
    const double tol = 1e-12 * y;
    out[i] = f;
    exact[i] = !(y - tol > lo && y + tol < hi);
  }
}

#if defined(__x86_64__)
// Eight values at a time with AVX2 and FMA, without gathers: srgb_encode_block_avx512's method
// (below) in 256-bit registers, where a variable permute reads a table of four doubles (vpermps on
// the doubles' 32-bit halves), so the tables have eight entries, two registers each, the pair
// chosen by a blend: m0 = 1 + j/8 (the mantissa's first 3 bits; m0a16 and inv_m016 at even
// entries), t = (m − m0)/m0 in [0, 1/8), (1 + t)^a by its binomial series to t^11 in fused
// multiply-adds; (2^e)^a for e = −8 .. −1 in two registers, e = −9 (x below 2^-8) by one more
// blend. (The gathers it replaces, three of four doubles per four values, cost about one element
// a cycle on Zen 4: docs/benchmarks.md, "AVX2 paths, twenty-fourth session".)
// Error of the fast y against srgb_encode's own double: srgb_encode_block_avx512's argument with
// its series bound replaced by this one's first dropped term, |C(a, 12)|·8⁻¹² < 0.0083·8⁻¹² =
// 1.3e-13 of x^a (alternating, shrinking terms) — under its 1.9e-13 — and a few more roundings
// (the three more terms; still under 4e-15): under 2e-13 of x^a, so the same margin of 2^15 units
// of y's last place around the float midpoint decides `exact` (a factor 7 over the bound).
// Entry k (0-7; only its low 3 bits count) of an eight-double table in two registers, for four
// lanes whose k is in both 32-bit halves of each 64-bit lane: vpermps reads 32-bit halves
// 2(k mod 4) and 2(k mod 4) + 1 of both registers (its index's low 3 bits), and k's bit 2,
// shifted to the lane's sign, picks the register.
__attribute__((target("avx2"))) inline __m256d lookup8_pd(__m256d lo, __m256d hi, __m256i kk) {
  const __m256i idx = _mm256_or_si256(_mm256_slli_epi32(kk, 1), _mm256_setr_epi32(0, 1, 0, 1, 0, 1, 0, 1));
  const __m256d a = _mm256_castps_pd(_mm256_permutevar8x32_ps(_mm256_castpd_ps(lo), idx));
  const __m256d b = _mm256_castps_pd(_mm256_permutevar8x32_ps(_mm256_castpd_ps(hi), idx));
  return _mm256_blendv_pd(a, b, _mm256_castsi256_pd(_mm256_slli_epi32(kk, 29)));
}
__attribute__((target("avx2,fma")))
void srgb_encode_block_avx2(const float* v, int n, float* out, int32_t* exact) {
  const PowTables& T = pow_tables();
  // two_e[e + 9]: e = −8 .. −5, −4 .. −1; e = −9 apart.
  const __m256d e_lo = _mm256_loadu_pd(T.two_e + 1), e_hi = _mm256_loadu_pd(T.two_e + 5), e_m9 = _mm256_set1_pd(T.two_e[0]);
  const __m256d a_lo = _mm256_setr_pd(T.m0a16[0], T.m0a16[2], T.m0a16[4], T.m0a16[6]);
  const __m256d a_hi = _mm256_setr_pd(T.m0a16[8], T.m0a16[10], T.m0a16[12], T.m0a16[14]);
  const __m256d i_lo = _mm256_setr_pd(T.inv_m016[0], T.inv_m016[2], T.inv_m016[4], T.inv_m016[6]);
  const __m256d i_hi = _mm256_setr_pd(T.inv_m016[8], T.inv_m016[10], T.inv_m016[12], T.inv_m016[14]);
  const __m256i low29 = _mm256_set1_epi64x((int64_t{1} << 29) - 1), mid = _mm256_set1_epi64x(int64_t{1} << 28);
  const __m256i margin = _mm256_set1_epi64x(int64_t{1} << 15), neg_margin = _mm256_set1_epi64x(-(int64_t{1} << 15));
  const __m256i dup_lo = _mm256_setr_epi32(0, 0, 1, 1, 2, 2, 3, 3), dup_hi = _mm256_setr_epi32(4, 4, 5, 5, 6, 6, 7, 7);
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256 xf = _mm256_loadu_ps(v + i);
    const __m256 fast = _mm256_and_ps(_mm256_cmp_ps(xf, _mm256_set1_ps(0.0031308f), _CMP_GT_OQ),
                                      _mm256_cmp_ps(xf, _mm256_set1_ps(1.f), _CMP_LT_OQ));
    const __m256i bits = _mm256_castps_si256(_mm256_blendv_ps(_mm256_set1_ps(0.5f), xf, fast));
    const __m256i e8 = _mm256_sub_epi32(_mm256_srli_epi32(bits, 23), _mm256_set1_epi32(127 - 8));  // −1 .. 7
    const __m256i mant = _mm256_and_si256(bits, _mm256_set1_epi32(0x7fffff));
    const __m256i j = _mm256_srli_epi32(mant, 20);
    // m − m0 = (mant − j·2^20)·2^-23: the mantissa's low 20 bits, exact.
    const __m256i low20 = _mm256_and_si256(mant, _mm256_set1_epi32(0xfffff));
    __m256d y[2];
    __m256i ok[2];
    for (int h = 0; h < 2; ++h) {
      const __m256i dup = h ? dup_hi : dup_lo;
      const __m256i jj = _mm256_permutevar8x32_epi32(j, dup), ee = _mm256_permutevar8x32_epi32(e8, dup);
      const __m256d dm = _mm256_mul_pd(_mm256_cvtepi32_pd(h ? _mm256_extracti128_si256(low20, 1) : _mm256_castsi256_si128(low20)),
                                       _mm256_set1_pd(0x1p-23));
      const __m256d t = _mm256_mul_pd(dm, lookup8_pd(i_lo, i_hi, jj));
      __m256d s = _mm256_set1_pd(T.c11);  // Horner: s = C(a, k) + t·s for k = 10 .. 0
      for (const double ck : {T.c10, T.c9, T.c8, T.c7, T.c6, T.c5, T.c4, T.c3, T.c2, T.c1, 1.0})
        s = _mm256_fmadd_pd(t, s, _mm256_set1_pd(ck));
      const __m256d te = _mm256_blendv_pd(lookup8_pd(e_lo, e_hi, ee), e_m9,
                                          _mm256_castsi256_pd(_mm256_cmpeq_epi32(ee, _mm256_set1_epi32(-1))));
      const __m256d p = _mm256_mul_pd(_mm256_mul_pd(te, lookup8_pd(a_lo, a_hi, jj)), s);
      y[h] = _mm256_fmsub_pd(_mm256_set1_pd(1.055), p, _mm256_set1_pd(0.055));
      // y's 29 bits below the float's 24 at least 2^15 from 2^28 (srgb_encode_block_avx512).
      const __m256i d = _mm256_sub_epi64(_mm256_and_si256(_mm256_castpd_si256(y[h]), low29), mid);
      ok[h] = _mm256_or_si256(_mm256_cmpgt_epi64(d, margin), _mm256_cmpgt_epi64(neg_margin, d));
    }
    // The two halves' 64-bit masks to eight 32-bit lanes (their low halves), in order.
    const __m256i ok8 = _mm256_permute4x64_epi64(
        _mm256_castps_si256(_mm256_shuffle_ps(_mm256_castsi256_ps(ok[0]), _mm256_castsi256_ps(ok[1]), 0x88)), 0xd8);
    const __m256i good = _mm256_and_si256(ok8, _mm256_castps_si256(fast));
    _mm256_storeu_ps(out + i, _mm256_set_m128(_mm256_cvtpd_ps(y[1]), _mm256_cvtpd_ps(y[0])));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(exact + i), _mm256_andnot_si256(good, _mm256_set1_epi32(1)));
  }
  srgb_encode_block(v + i, n - i, out + i, exact + i);
}
// Eight values at a time with AVX-512F, without gathers (a gather of eight doubles costs about
// one element a cycle on Zen 4; these read their tables by two-register permutes) and with fewer
// double operations: the same decision as srgb_encode_block, from a coarser table. x^a =
// (2^e)^a · m0^a · (1 + t)^a with m0 = 1 + j/16 (the mantissa's first 4 bits: 16-entry tables
// m0a16, inv_m016 and two_e in two registers each) and t = (m − m0)/m0 in [0, 1/16); (1 + t)^a
// by its binomial series to t^8, in fused multiply-adds (an approximation whose error is bounded
// below; fusing only removes roundings).
// Error of the fast y = 1.055·x^a − 0.055 against srgb_encode's own double: the series' first
// dropped term |C(a, 9)|·t^9 < 0.013·16⁻⁹ = 1.9e-13 relative to x^a (the terms alternate in sign
// and shrink, so it bounds the remainder), the tables' (std::pow, < 1 ulp each) and the ~20
// roundings' (< 3e-15), std::pow's own < 1 ulp: under 2e-13 of x^a, so under 5e-13·y (1.055·x^a
// ≤ 2.4·y past the toe, srgb_encode_block's comment), i.e. under 5e-13·2^53 < 4 600 units of
// y's last place (y < 2^(e+1) in its binade [2^e, 2^(e+1)), whose double ulp is 2^(e−52)).
// The float nearest y is decided by y's 29 bits below the float's 24: a midpoint between two
// floats of y's binade (or, at its top, between the largest and 2^(e+1)) is where they read
// 2^28. Where they lie farther than 2^15 units (a factor 7 over the bound) from 2^28, the exact
// double lies on the same side of that midpoint, so both round to the same float; elsewhere
// (about one value in 8 000 besides the toe, white and NaN) `exact` is set.
// The doubles in 512-bit registers, the float tests and integer steps in 256-bit ones.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"  // GCC 12's _mm512_undefined_*() (as in darken.cpp)
__attribute__((target("avx512f")))
void srgb_encode_block_avx512(const float* v, int n, float* out, int32_t* exact) {
  const PowTables& T = pow_tables();
  const __m512d one = _mm512_set1_pd(1.0);
  const __m512d c1 = _mm512_set1_pd(T.c1), c2 = _mm512_set1_pd(T.c2), c3 = _mm512_set1_pd(T.c3), c4 = _mm512_set1_pd(T.c4);
  const __m512d c5 = _mm512_set1_pd(T.c5), c6 = _mm512_set1_pd(T.c6), c7 = _mm512_set1_pd(T.c7), c8 = _mm512_set1_pd(T.c8);
  const __m512d e_lo = _mm512_loadu_pd(T.two_e), e_hi = _mm512_loadu_pd(T.two_e + 8);
  const __m512d a_lo = _mm512_loadu_pd(T.m0a16), a_hi = _mm512_loadu_pd(T.m0a16 + 8);
  const __m512d i_lo = _mm512_loadu_pd(T.inv_m016), i_hi = _mm512_loadu_pd(T.inv_m016 + 8);
  const __m512i low29 = _mm512_set1_epi64((int64_t{1} << 29) - 1), mid = _mm512_set1_epi64(int64_t{1} << 28);
  const __m512i margin = _mm512_set1_epi64(int64_t{1} << 15);
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256 xf = _mm256_loadu_ps(v + i);
    const __m256 fast = _mm256_and_ps(_mm256_cmp_ps(xf, _mm256_set1_ps(0.0031308f), _CMP_GT_OQ),
                                      _mm256_cmp_ps(xf, _mm256_set1_ps(1.f), _CMP_LT_OQ));
    const __m256i bits = _mm256_castps_si256(_mm256_blendv_ps(_mm256_set1_ps(0.5f), xf, fast));
    const __m512i e9 = _mm512_cvtepi32_epi64(_mm256_sub_epi32(_mm256_srli_epi32(bits, 23), _mm256_set1_epi32(127 - 9)));
    const __m256i mant = _mm256_and_si256(bits, _mm256_set1_epi32(0x7fffff));
    const __m256i j = _mm256_srli_epi32(mant, 19);
    const __m512i j64 = _mm512_cvtepi32_epi64(j);
    // m − m0 = (mant − j·2^19)·2^-23: the mantissa's low 19 bits, exact.
    const __m512d dm = _mm512_mul_pd(_mm512_cvtepi32_pd(_mm256_and_si256(mant, _mm256_set1_epi32(0x7ffff))),
                                     _mm512_set1_pd(0x1p-23));
    const __m512d t = _mm512_mul_pd(dm, _mm512_permutex2var_pd(i_lo, j64, i_hi));
    __m512d s = _mm512_fmadd_pd(t, c8, c7);
    s = _mm512_fmadd_pd(t, s, c6);
    s = _mm512_fmadd_pd(t, s, c5);
    s = _mm512_fmadd_pd(t, s, c4);
    s = _mm512_fmadd_pd(t, s, c3);
    s = _mm512_fmadd_pd(t, s, c2);
    s = _mm512_fmadd_pd(t, s, c1);
    s = _mm512_fmadd_pd(t, s, one);
    const __m512d p = _mm512_mul_pd(_mm512_mul_pd(_mm512_permutex2var_pd(e_lo, e9, e_hi),
                                                  _mm512_permutex2var_pd(a_lo, j64, a_hi)), s);
    const __m512d y = _mm512_fmsub_pd(_mm512_set1_pd(1.055), p, _mm512_set1_pd(0.055));
    const __m512i below = _mm512_and_si512(_mm512_castpd_si512(y), low29);
    const __mmask8 ok = _mm512_cmpgt_epi64_mask(_mm512_abs_epi64(_mm512_sub_epi64(below, mid)), margin);
    const __mmask16 good = static_cast<__mmask16>(ok & _mm256_movemask_ps(fast));
    _mm256_storeu_ps(out + i, _mm512_cvtpd_ps(y));
    // exact: 0 where good, else 1 (lanes 0-7 of a 512-bit vector).
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(exact + i),
                        _mm512_castsi512_si256(_mm512_mask_mov_epi32(_mm512_set1_epi32(1), good, _mm512_setzero_si512())));
  }
  srgb_encode_block(v + i, n - i, out + i, exact + i);
}
#pragma GCC diagnostic pop
#endif
// The widest instruction set work_luma_row's 2x2 means and the encode may take (work_luma_max_isa).
int luma_max_isa = 2;
}  // namespace

void srgb_encode_floats(const float* v, int n, float* out) {
  constexpr int kBlock = 256;
  float fast[kBlock];
  int32_t exact[kBlock];
#if defined(__x86_64__)
  static const int have = photosite::detail::machine_isa_level();
  const int isa = std::min(have, luma_max_isa);
#endif
  for (int b = 0; b < n; b += kBlock) {
    const int m = std::min(kBlock, n - b);
#if defined(__x86_64__)
    if (isa == 2) srgb_encode_block_avx512(v + b, m, fast, exact);
    else if (isa == 1) srgb_encode_block_avx2(v + b, m, fast, exact);
    else
#endif
      srgb_encode_block(v + b, m, fast, exact);
    // Most blocks have no value to take exactly: copied whole (a loop the compiler vectorises).
    int32_t any = 0;
    for (int i = 0; i < m; ++i) any |= exact[i];
    if (!any) {
      std::copy_n(fast, m, out + b);
      continue;
    }
    for (int i = 0; i < m; ++i)
      out[b + i] = exact[i] ? static_cast<float>(srgb_encode(std::clamp(v[b + i], 0.f, 1.f))) : fast[i];
  }
}

WorkSize work_size(int W, int H, int work_max_width) {
  WorkSize s;
  s.scale = W > work_max_width ? static_cast<double>(work_max_width) / W : 1.0;
  s.width = std::max(1, static_cast<int>(std::lround(W * s.scale)));
  s.height = std::max(1, static_cast<int>(std::lround(H * s.scale)));
  s.halving = W == 2 * s.width && H == 2 * s.height && s.width % 16 == 0;
  return s;
}

namespace {
// Luminance (Rec. 709 weights on linear sRGB) of pixel x of an interleaved RGB row.
inline float luma_at(const float* r, int x) { return 0.2126f * r[3 * x] + 0.7152f * r[3 * x + 1] + 0.0722f * r[3 * x + 2]; }
#if defined(__x86_64__)
// The 2x2 means of work_luma_row, eight working pixels at a time from x (a multiple of 8) up to
// n: each pixel's luminance (0.2126·r + 0.7152·g) + 0.0722·b, then ((a + b) + (c + d))·0.25, the
// same float operations per pixel as the scalar loop (no fused multiply-adds), so the same bits.
// Four source pixels per 128-bit lane split into R, G and B by in-lane shuffles; returns where it
// stopped.
constexpr int shf(int a, int b, int c, int d) { return a | b << 2 | c << 4 | d << 6; }
__attribute__((target("avx2"))) inline __m256 luma8(const float* s) {
  // Lane 0: pixels 0-3 (s[0..11]), lane 1: pixels 4-7 (s[12..23]).
  const __m256 a = _mm256_loadu2_m128(s + 12, s), b = _mm256_loadu2_m128(s + 16, s + 4), d = _mm256_loadu2_m128(s + 20, s + 8);
  const __m256 R = _mm256_shuffle_ps(a, _mm256_shuffle_ps(b, d, shf(2, 2, 1, 1)), shf(0, 3, 0, 2));
  const __m256 G = _mm256_shuffle_ps(_mm256_shuffle_ps(a, b, shf(1, 1, 0, 0)), _mm256_shuffle_ps(b, d, shf(3, 3, 2, 2)), shf(0, 2, 0, 2));
  const __m256 B = _mm256_shuffle_ps(_mm256_shuffle_ps(a, b, shf(2, 2, 1, 1)), _mm256_shuffle_ps(d, d, shf(0, 3, 0, 3)), shf(0, 2, 0, 1));
  return _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(0.2126f), R), _mm256_mul_ps(_mm256_set1_ps(0.7152f), G)),
                       _mm256_mul_ps(_mm256_set1_ps(0.0722f), B));
}
// a + b of eight working pixels of one row (16 source pixels from s): lanes w0 w1 w4 w5 | w2 w3 w6 w7.
__attribute__((target("avx2"))) inline __m256 pair_sums8(const float* s) {
  const __m256 L = luma8(s), L2 = luma8(s + 24);  // l0-3 | l4-7, l8-11 | l12-15
  return _mm256_add_ps(_mm256_shuffle_ps(L, L2, shf(0, 2, 0, 2)), _mm256_shuffle_ps(L, L2, shf(1, 3, 1, 3)));
}
__attribute__((target("avx2"))) int work_luma_avx2(const float* r0, const float* r1, int x, int n, float* o) {
  for (; x + 8 <= n; x += 8) {
    const __m256 m = _mm256_mul_ps(_mm256_add_ps(pair_sums8(r0 + 6 * x), pair_sums8(r1 + 6 * x)), _mm256_set1_ps(0.25f));
    // 64-bit pairs (w0 w1)(w4 w5)(w2 w3)(w6 w7) into order.
    _mm256_storeu_ps(o + x, _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(m), shf(0, 2, 1, 3))));
  }
  return x;
}
// Sixteen working pixels at a time in 512-bit registers: the 48 floats of 16 source pixels split
// into R, G and B by two two-register permutes each, the even and odd pixels' luminances of 32
// source pixels by one more each.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"  // GCC 12's _mm512_undefined_*() (as in darken.cpp)
__attribute__((target("avx512f"))) inline __m512 luma16(const float* s) {
  const __m512 a = _mm512_loadu_ps(s), b = _mm512_loadu_ps(s + 16), c = _mm512_loadu_ps(s + 32);
  // Pixel k's sample j is float 3k + j of a‖b (0-31) for the first pixels, of c (16 + (3k + j − 32)) after.
  const __m512i r1 = _mm512_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21, 24, 27, 30, 0, 0, 0, 0, 0);
  const __m512i r2 = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 17, 20, 23, 26, 29);
  const __m512i g1 = _mm512_setr_epi32(1, 4, 7, 10, 13, 16, 19, 22, 25, 28, 31, 0, 0, 0, 0, 0);
  const __m512i g2 = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 18, 21, 24, 27, 30);
  const __m512i b1 = _mm512_setr_epi32(2, 5, 8, 11, 14, 17, 20, 23, 26, 29, 0, 0, 0, 0, 0, 0);
  const __m512i b2 = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 16, 19, 22, 25, 28, 31);
  const __m512 R = _mm512_permutex2var_ps(_mm512_permutex2var_ps(a, r1, b), r2, c);
  const __m512 G = _mm512_permutex2var_ps(_mm512_permutex2var_ps(a, g1, b), g2, c);
  const __m512 B = _mm512_permutex2var_ps(_mm512_permutex2var_ps(a, b1, b), b2, c);
  return _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(_mm512_set1_ps(0.2126f), R), _mm512_mul_ps(_mm512_set1_ps(0.7152f), G)),
                       _mm512_mul_ps(_mm512_set1_ps(0.0722f), B));
}
__attribute__((target("avx512f"))) inline __m512 pair_sums16(const float* s) {
  const __m512 L = luma16(s), L2 = luma16(s + 48);
  const __m512i even = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
  const __m512i odd = _mm512_setr_epi32(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31);
  return _mm512_add_ps(_mm512_permutex2var_ps(L, even, L2), _mm512_permutex2var_ps(L, odd, L2));
}
__attribute__((target("avx512f"))) int work_luma_avx512(const float* r0, const float* r1, int x, int n, float* o) {
  for (; x + 16 <= n; x += 16)
    _mm512_storeu_ps(o + x, _mm512_mul_ps(_mm512_add_ps(pair_sums16(r0 + 6 * x), pair_sums16(r1 + 6 * x)), _mm512_set1_ps(0.25f)));
  return x;
}
#pragma GCC diagnostic pop
const int kLumaIsa = photosite::detail::machine_isa_level();
__attribute__((target("avx512f"))) int luma_row_avx512(const float* r, int W, float* l) {
  int x = 0;
  for (; x + 16 <= W; x += 16) _mm512_storeu_ps(l + x, luma16(r + 3 * x));
  return x;
}
__attribute__((target("avx2"))) int luma_row_avx2(const float* r, int W, float* l) {
  int x = 0;
  for (; x + 8 <= W; x += 8) _mm256_storeu_ps(l + x, luma8(r + 3 * x));
  return x;
}
#endif
// The luminance (luma_at) of an interleaved RGB row of W pixels into l: luma16 or luma8 where the
// machine has them (the same float operations per pixel, so the same bits), then one at a time.
void luma_row(const float* r, int W, float* l) {
  int x = 0;
#if defined(__x86_64__)
  const int isa = std::min(kLumaIsa, luma_max_isa);
  if (isa == 2) x = luma_row_avx512(r, W, l);
  else if (isa == 1) x = luma_row_avx2(r, W, l);
#endif
  for (; x < W; ++x) l[x] = luma_at(r, x);
}

// Area means (the decimation of OpenCV's INTER_AREA: each working pixel the mean of the source
// pixels under its cell, edge pixels weighted by the part of them it covers), separable: the
// cell [d·s, d·s + s) of one axis, s = 1/(d_size/s_size) as OpenCV takes it, covers a partial
// pixel before its first whole one (weight (⌈d·s⌉ − d·s)/c), its whole pixels (1/c) and a
// partial one after (min(d·s + s − ⌊d·s + s⌋, 1, c)/c), c = min(s, s_size − d·s) the cell's width
// inside the image; parts under 10⁻³ of a pixel are left out. Built with OpenCV's expressions,
// so the same float weights.
struct AreaTaps {
  std::vector<int> begin;  // taps of output d: [begin[d], begin[d + 1])
  std::vector<int> src;
  std::vector<float> weight;
};
AreaTaps area_taps(int ssize, int dsize) {
  const double scale = 1.0 / (static_cast<double>(dsize) / ssize);
  AreaTaps t;
  t.begin.reserve(dsize + 1);
  for (int d = 0; d < dsize; ++d) {
    t.begin.push_back(static_cast<int>(t.src.size()));
    const double f1 = d * scale, f2 = f1 + scale, cell = std::min(scale, ssize - f1);
    int s2 = static_cast<int>(std::floor(f2));
    s2 = std::min(s2, ssize - 1);
    const int s1 = std::min(static_cast<int>(std::ceil(f1)), s2);
    auto tap = [&](int i, float w) { t.src.push_back(i), t.weight.push_back(w); };
    if (s1 - f1 > 1e-3) tap(s1 - 1, static_cast<float>((s1 - f1) / cell));
    for (int i = s1; i < s2; ++i) tap(i, static_cast<float>(1.0 / cell));
    if (f2 - s2 > 1e-3) tap(s2, static_cast<float>(std::min(std::min(f2 - s2, 1.0), cell) / cell));
  }
  t.begin.push_back(static_cast<int>(t.src.size()));
  return t;
}
// Whether cv::resize's INTER_AREA takes W x H to ww x wh by integer block means (its "fast"
// path: both scales, as it computes them, integers to within DBL_EPSILON), not area_taps' weights.
bool area_scale_is_integer(int W, int H, int ww, int wh) {
  const double sx = 1.0 / (static_cast<double>(ww) / W), sy = 1.0 / (static_cast<double>(wh) / H);
  return std::fabs(sx - std::lround(sx)) < DBL_EPSILON && std::fabs(sy - std::lround(sy)) < DBL_EPSILON;
}
// The area means of the day image's luminance (luma_at), sRGB-encoded (srgb_encode_floats, as the
// other paths encode their means) into out (ww x wh, one channel), each row on its own: per
// source row of the cell, its luminance, then the row's horizontal taps summed in order into buf
// (buf[d] += l[src]·w, from 0), then the rows summed with their vertical weights β
// (the first β·buf added to 0, the next ones added in order): cv::resize's order of float
// operations for INTER_AREA on one channel (its rows, split among its threads, are each computed
// the same way), so the same bits (test SceneGeometry.WorkLumaFractionalScaleIsOpenCvsAreaResize).
// On the OpenMP threads, where cv::resize ran on OpenCV's own, which contended with OpenMP's
// spinning ones on a 2-core machine (5-6 ms for the 1024x512 working image of a 1280x640 frame,
// against 2 ms on one thread: docs/benchmarks.md, "Fifty-third session: frames of other sizes").
void area_mean_luma(const ImageF& day, ImageF& out) {
  const int W = day.width(), H = day.height(), ww = out.width(), wh = out.height();
  const AreaTaps tx = area_taps(W, ww), ty = area_taps(H, wh);
#pragma omp parallel
  {
    // A source row's horizontal sums depend on that row only, and a cell's last source row is
    // mostly the next cell's first: the sums of the last row made are kept (cached, its row
    // cached_y) and taken again, not made twice.
    std::vector<float> l(W), made(ww), cached(ww), sum(ww);
    int cached_y = -1;
#pragma omp for schedule(static)
    for (int dy = 0; dy < wh; ++dy) {
      int last_made = -1;
      for (int k = ty.begin[dy]; k < ty.begin[dy + 1]; ++k) {
        const int sy = ty.src[k];
        const float* buf = cached.data();
        if (sy != cached_y) {
          luma_row(day.row(sy), W, l.data());
          std::fill(made.begin(), made.end(), 0.f);
          for (int d = 0; d < ww; ++d)
            for (int j = tx.begin[d]; j < tx.begin[d + 1]; ++j) made[d] += l[tx.src[j]] * tx.weight[j];
          buf = made.data();
          last_made = sy;
        }
        const float beta = ty.weight[k];
        if (k == ty.begin[dy])
          for (int d = 0; d < ww; ++d) sum[d] = 0.f + beta * buf[d];
        else
          for (int d = 0; d < ww; ++d) sum[d] += beta * buf[d];
      }
      // The cell's last row, if made here, is kept for the next cell.
      if (last_made >= 0 && last_made == ty.src[ty.begin[dy + 1] - 1]) {
        std::swap(made, cached);
        cached_y = last_made;
      }
      srgb_encode_floats(sum.data(), ww, out.row(dy));
    }
  }
}
}  // namespace

void work_luma_max_isa(int isa) { luma_max_isa = isa; }

void work_luma_row(const ImageF& day, int y, float* o) {
  // Exact halving: each working pixel is the mean of a 2x2 block, summed as (a + b) + (c + d)
  // and scaled by 0.25 — the arithmetic of OpenCV's INTER_AREA for this case (its vector path,
  // which covers rows whose width is a multiple of 16), so the same bits as cv::resize, in one
  // pass per pair of rows without the full-resolution luminance image.
  const float* r0 = day.row(2 * y);
  const float* r1 = day.row(2 * y + 1);
  const int ww = day.width() / 2;
  int x = 0;
#if defined(__x86_64__)
  const int isa = std::min(kLumaIsa, luma_max_isa);
  if (isa == 2) x = work_luma_avx512(r0, r1, x, ww, o);
  if (isa >= 1) x = work_luma_avx2(r0, r1, x, ww, o);
#endif
  for (; x < ww; ++x) {
    const float a = luma_at(r0, 2 * x), b = luma_at(r0, 2 * x + 1);
    const float c = luma_at(r1, 2 * x), d = luma_at(r1, 2 * x + 1);
    o[x] = ((a + b) + (c + d)) * 0.25f;
  }
  srgb_encode_floats(o, ww, o);
}

WorkImages make_work_images(const ImageF& day, const ImageU16& labels, int work_max_width) {
  return make_work_images_with(day, labels, work_max_width, nullptr);
}

WorkImages make_work_images_with(const ImageF& day, const ImageU16& labels, int work_max_width, ImageF* luma) {
  WorkImages w;
  const int W = day.width(), H = day.height();
  const WorkSize ws = work_size(W, H, work_max_width);
  w.scale = ws.scale;
  const int ww = ws.width, wh = ws.height;
  // Luminance, area-averaged to the working size, then sRGB-encoded so that contrasts are
  // perceptual.
  if (luma) {
    if (!luma->same_shape(ww, wh) || luma->channels() != 1) fail("make_work_images: a made luminance of the wrong size");
    w.luma = std::move(*luma);
  } else if (ws.halving) {
    w.luma = ImageF(ww, wh, 1, uninitialized);
#pragma omp parallel for schedule(static)
    for (int y = 0; y < wh; ++y) work_luma_row(day, y, w.luma.row(y));
  } else if (ww != W && !area_scale_is_integer(W, H, ww, wh)) {
    // A fractional scale (KITTI's 1242 or BDD100K's 1280 columns to the 1024 working ones): the
    // area means made here (area_mean_luma, the same bits as cv::resize's INTER_AREA), on the
    // OpenMP threads, without the full-resolution luminance image.
    w.luma = ImageF(ww, wh, 1, uninitialized);
    area_mean_luma(day, w.luma);
  } else {
    w.luma = ImageF(ww, wh, 1, uninitialized);
    // The full-resolution luminance in an Image (its buffer from the frame buffers' allocator,
    // include/photosite/frame_buffers.h, where a program keeps them: 32 MiB at 4096x2048, which a
    // cv::Mat of its own page-faulted in afresh every frame), seen by OpenCV without a copy.
    // (An integer scale: OpenCV's INTER_AREA then takes its block means.)
    ImageF lum_buf(W, H, 1, uninitialized);
    cv::Mat lum(H, W, CV_32F, lum_buf.data());
#pragma omp parallel for schedule(static)
    for (int y = 0; y < H; ++y) {
      const float* r = day.row(y);
      float* o = lum.ptr<float>(y);
      for (int x = 0; x < W; ++x) o[x] = luma_at(r, x);
    }
    cv::Mat small;
    if (ww != W) cv::resize(lum, small, cv::Size(ww, wh), 0, 0, cv::INTER_AREA);
    else small = lum;
#pragma omp parallel for schedule(static)
    for (int y = 0; y < wh; ++y) {
      const float* in = small.ptr<float>(y);
      float* o = w.luma.row(y);
      srgb_encode_floats(in, ww, o);
    }
  }
  w.labels = ww == W ? labels : resize_nearest(labels, ww, wh);
  return w;
}

// One row of lane_markings (lanes_detail.h), columns [w, W − w): 255 where the pixel is road (or parking) and
// brighter than both sides. Horizontal accumulation (Batista et al.): h = 2c − l − r − |l − r|,
// brighter than both sides by the threshold, with the side asymmetry subtracted so road edges
// and shadows do not respond; with rows up and down (u, d: null where the vertical pass does not
// reach), the same across rows, else v = 0. Branch-free per pixel so that the clones take 8 or 16
// pixels at a time; the same float operations per pixel on every path (no contraction).
PHOTOSITE_TARGET_CLONES
void lane_row(const float* __restrict r, const float* __restrict up, const float* __restrict down,
              const uint16_t* __restrict lab, int W, int w, float thr, uint8_t* __restrict o) {
  const uint16_t road = static_cast<uint16_t>(Label::Road), parking = static_cast<uint16_t>(Label::Parking);
  if (up) {
    for (int x = w; x < W - w; ++x) {
      const float l = r[x - w], c = r[x], rr = r[x + w];
      const float h = 2 * c - l - rr - std::fabs(l - rr);
      const float u = up[x], d = down[x];
      const float v = 2 * c - u - d - std::fabs(u - d);
      const bool on_road = lab[x] == road || lab[x] == parking;
      o[x] = on_road && (h > 2 * thr || v > 2 * thr) ? 255 : o[x];
    }
  } else {
    for (int x = w; x < W - w; ++x) {
      const float l = r[x - w], c = r[x], rr = r[x + w];
      const float h = 2 * c - l - rr - std::fabs(l - rr);
      const bool on_road = lab[x] == road || lab[x] == parking;
      o[x] = on_road && (h > 2 * thr || 0.f > 2 * thr) ? 255 : o[x];
    }
  }
}

ImageF lane_blur(const ImageF& luma, double sigma_px, int bands) {
  const int W = luma.width(), H = luma.height();
  ImageF out(W, H, 1, uninitialized);
  cv::Mat src(H, W, CV_32F, const_cast<float*>(luma.data())), dst(H, W, CV_32F, out.data());
  // Bands of rows, blurred in parallel: each band a view (ROI) of the whole image, whose rows
  // beyond the band OpenCV's filter reads as its border (it takes the parent's pixels outside an
  // ROI unless told BORDER_ISOLATED; the image's own edges get the default BORDER_REFLECT_101 as
  // before), so every pixel is the whole image's blur: the same bits for any band count, and
  // so for any thread count (the serial blur was the lane stage's part that did not scale). One
  // band per thread: each band filters the kernel's reach beyond it again (4 rows a side at
  // σ = 1), so no more bands than threads.
  if (bands <= 0) bands = std::clamp(omp_get_max_threads(), 1, 8);
  bands = std::min(bands, std::max(1, H));
#pragma omp parallel for schedule(static)
  for (int b = 0; b < bands; ++b) {
    const int y0 = H * b / bands, y1 = H * (b + 1) / bands;
    if (y1 <= y0) continue;
    cv::Mat band = dst.rowRange(y0, y1);
    cv::GaussianBlur(src.rowRange(y0, y1), band, cv::Size(0, 0), sigma_px);
  }
  return out;
}

ImageU8 lane_markings(const ImageF& luma, const ImageU16& labels, const ScenePreset& p) {
  return lane_markings_with_grey(luma, labels, p, nullptr);
}

ImageU8 lane_markings_with_grey(const ImageF& luma, const ImageU16& labels, const ScenePreset& p, ImageU8* grey) {
  const int W = luma.width(), H = luma.height();
  ImageU8 out(W, H, 1, 0);
  if (grey) {
    if (!labels.same_shape(W, H)) fail("lane_markings: labels of another size than the luminance");
    *grey = ImageU8(W, H, 1, uninitialized);
  }
  auto road = [&](int x, int y) {
    const int id = labels.at(x, y);
    return id == static_cast<int>(Label::Road) || id == static_cast<int>(Label::Parking);
  };
  int y_top = -1;
  for (int y = 0; y < H && y_top < 0; ++y)
    for (int x = 0; x < W; ++x)
      if (road(x, y)) { y_top = y; break; }
  // The grey rendering's rows above the road (every row where there is none): no markings there.
  if (grey) {
    const int y_end = y_top < 0 ? H : y_top;
#pragma omp parallel for schedule(static)
    for (int y = 0; y < y_end; ++y) segmentation_grey_row(labels.row(y), out.row(y), W, grey->row(y));
  }
  if (y_top < 0) return out;  // no road: no markings
  const ImageF blurred = p.lane_blur_sigma_px > 0 ? lane_blur(luma, p.lane_blur_sigma_px) : ImageF();
  const ImageF& blur = p.lane_blur_sigma_px > 0 ? blurred : luma;
  const float thr = static_cast<float>(p.lane_contrast_threshold);
  // Marking width in pixels grows linearly below the top of the road (perspective): about 1.5%
  // of the width at the bottom row (a 0.15 m line on a ~10 m wide view), at least 2 px.
  const double span = std::max(1, H - 1 - y_top);
#pragma omp parallel for schedule(static, 8)  // road pixels crowd the lower rows: interleave
  for (int y = y_top; y < H; ++y) {
    const int w = std::max(2, static_cast<int>(std::lround(0.015 * W * (y - y_top) / span)));
    const int wv = std::max(1, w / 2);
    const bool vertical = y - wv >= 0 && y + wv < H;  // vertical pass: transverse markings, stop lines
    lane_row(blur.row(y), vertical ? blur.row(y - wv) : nullptr, vertical ? blur.row(y + wv) : nullptr, labels.row(y), W, w,
             thr, out.row(y));
    // The row's markings are final (each row is written by its own iteration only).
    if (grey) segmentation_grey_row(labels.row(y), out.row(y), W, grey->row(y));
  }
  return out;
}

}  // namespace photosite::scene

namespace photosite::scene {

// drop_tram_rails (declared in night.h with its rule). Each marking component's pixels go to the
// ground (CameraGeometry::ground_point at the pixel centre in frame coordinates, per run of a row:
// its first pixel, the others by X's step along the row) and their line
// X = a + b·D is fitted by least squares over D; two straight components whose lines run
// side by side at a rail gauge plus a head's width are a track. The head width: tram groove rails
// have heads of about 55-60 mm (EN 14811 profiles such as Ri60), Vignole rails 60-75 mm; 0.065 m
// is taken, and the 0.15 m tolerance covers both and the metric scene's error.
int drop_tram_rails(ImageU8& lanes_work, double work_scale, const CameraGeometry& g, const ScenePreset& p,
                    ImageU8* rails) {
  const int W = lanes_work.width(), H = lanes_work.height();
  if (rails) *rails = ImageU8(W, H, 1, uint8_t{0});
  if (p.tram_gauges_m.empty() || W < 2 || H < 2) return 0;
  constexpr double kHead = 0.065, kTol = 0.15, kMinLength = 3.0, kMaxSlope = 0.3, kMaxRms = 0.15;
  // The marking mask is sparse (a few thousand of half a million working pixels): its 8-connected
  // components by its runs (mask_runs).
  const std::vector<MaskRun> runs = mask_runs(lanes_work.data(), W, H, true);
  if (runs.size() < 2) return 0;
  // Per component the least-squares sums of its pixels' ground points (X over D); a row of flat
  // ground has one D, and X is linear in the column: X = X(x0) + z·Δu/f.
  struct Fit {
    double n = 0, sD = 0, sX = 0, sDD = 0, sDX = 0, sXX = 0, Dmin = 1e300, Dmax = -1e300;
    double a = 0, b = 0;
    bool rail = false;
  };
  std::vector<Fit> f(runs.size());
  for (size_t i = 0; i < runs.size(); ++i) {
    const MaskRun& r = runs[i];
    double X0, D, z;
    const double v = (r.y + 0.5) / work_scale - 0.5;
    if (!g.ground_point((r.x0 + 0.5) / work_scale - 0.5, v, &X0, &D, &z)) continue;
    const double step = z / (work_scale * g.f_px);  // X per working column
    Fit& c = f[r.root];
    for (int x = r.x0; x < r.x1; ++x) {
      const double X = X0 + (x - r.x0) * step;
      c.n += 1;
      c.sD += D;
      c.sX += X;
      c.sDD += D * D;
      c.sDX += D * X;
      c.sXX += X * X;
    }
    c.Dmin = std::min(c.Dmin, D);
    c.Dmax = std::max(c.Dmax, D);
  }
  std::vector<int> lines;
  for (size_t i = 0; i < runs.size(); ++i) {
    Fit& c = f[i];
    if (runs[i].root != static_cast<int>(i) || c.n < 8 || c.Dmax - c.Dmin < kMinLength) continue;
    const double mD = c.sD / c.n, mX = c.sX / c.n;
    const double vDD = c.sDD / c.n - mD * mD, vDX = c.sDX / c.n - mD * mX, vXX = c.sXX / c.n - mX * mX;
    if (!(vDD > 0)) continue;
    c.b = vDX / vDD;
    c.a = mX - c.b * mD;
    const double rms2 = vXX - c.b * vDX;  // the residual's mean square (least squares' identity)
    if (std::fabs(c.b) > kMaxSlope || rms2 > kMaxRms * kMaxRms) continue;
    lines.push_back(static_cast<int>(i));
  }
  for (size_t i = 0; i < lines.size(); ++i)
    for (size_t j = i + 1; j < lines.size(); ++j) {
      Fit &p1 = f[lines[i]], &p2 = f[lines[j]];
      const double lo = std::max(p1.Dmin, p2.Dmin), hi = std::min(p1.Dmax, p2.Dmax);
      if (hi - lo < kMinLength) continue;
      const double s_lo = std::fabs((p2.a - p1.a) + (p2.b - p1.b) * lo);
      const double s_hi = std::fabs((p2.a - p1.a) + (p2.b - p1.b) * hi);
      for (const double gauge : p.tram_gauges_m)
        if (std::fabs(s_lo - (gauge + kHead)) <= kTol && std::fabs(s_hi - (gauge + kHead)) <= kTol) {
          p1.rail = p2.rail = true;
          break;
        }
    }
  int cleared = 0;
  for (size_t i = 0; i < runs.size(); ++i) {
    const MaskRun& r = runs[i];
    if (!f[r.root].rail) continue;
    std::fill(lanes_work.row(r.y) + r.x0, lanes_work.row(r.y) + r.x1, uint8_t{0});
    if (rails) std::fill(rails->row(r.y) + r.x0, rails->row(r.y) + r.x1, uint8_t{255});
    cleared += r.x1 - r.x0;
  }
  return cleared;
}

int texture_under_rails(ImageF& texture, const ImageU16& labels, const ImageU8& rails, const CameraGeometry& g) {
  const int W = texture.width(), H = texture.height(), C = texture.channels();
  int changed = 0;
  for (int y = 0; y < H; ++y) {
    const uint8_t* m = rails.row(y);
    if (std::find_if(m, m + W, [](uint8_t v) { return v != 0; }) == m + W) continue;  // no rail in this row
    const double z = g.ground_depth_m(y);
    if (!(z > 0) || !std::isfinite(z)) continue;
    const int reach = static_cast<int>(std::min<double>(W, std::ceil(0.12 * g.f_px / z) + 2)) + 3;
    const uint16_t* id = labels.row(y);
    float* t = texture.row(y);
    for (int x = 0; x < W;) {
      if (!m[x]) {
        ++x;
        continue;
      }
      int x1 = x;
      while (x1 < W && m[x1]) ++x1;
      const uint16_t lab = id[x];
      auto flank = [&](int k) { return id[k] == lab && !m[k]; };
      // Each side's sample: the mean texture of the run's label off the mask over the last 3
      // pixels of its window (`reach` pixels from the run's end, past the rail's top); none where
      // the image border or other labels leave no such pixel.
      float lv[4] = {0, 0, 0, 0}, rv[4] = {0, 0, 0, 0};
      int ln = 0, rn = 0;
      for (int k = x - reach; k < x - reach + 3; ++k)
        if (k >= 0 && k < x && flank(k)) {
          for (int c = 0; c < C && c < 4; ++c) lv[c] += t[C * k + c];
          ++ln;
        }
      for (int k = x1 + reach - 3; k < x1 + reach; ++k)
        if (k >= x1 && k < W && flank(k)) {
          for (int c = 0; c < C && c < 4; ++c) rv[c] += t[C * k + c];
          ++rn;
        }
      if (ln || rn) {
        float v[4] = {0, 0, 0, 0};
        for (int c = 0; c < C && c < 4; ++c)
          v[c] = ln && rn ? 0.5f * (lv[c] / ln + rv[c] / rn) : ln ? lv[c] / ln : rv[c] / rn;
        // Painted: the run and its windows up to the samples.
        const int a = std::max(0, x - reach + 3), b = std::min(W, x1 + reach - 3);
        for (int k = a; k < b; ++k) {
          if (id[k] != lab) continue;
          for (int c = 0; c < C && c < 4; ++c) t[C * k + c] = v[c];
          ++changed;
        }
      }
      x = x1;
    }
  }
  return changed;
}

}  // namespace photosite::scene
