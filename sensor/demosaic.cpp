// Demosaic dispatch, the method list, and bilinear interpolation.
#include "photosite/sensor/demosaic.h"

#include <algorithm>
#include <atomic>
#include <cctype>
#ifdef __SSE2__
#include <emmintrin.h>
#endif
#ifdef __x86_64__
#include <immintrin.h>
#endif

#include "core/isa_detail.h"
#include "demosaic_detail.h"
#include "photosite/error.h"

namespace photosite {

namespace {
struct MethodInfo {
  DemosaicMethod method;
  const char* name;
  const char* alias;
  const char* description;
};
constexpr MethodInfo kMethods[] = {
    {DemosaicMethod::Bilinear, "bilinear", "", "per-colour bilinear interpolation (3x3)"},
    {DemosaicMethod::Malvar, "malvar", "mhc",
     "Malvar-He-Cutler 2004 gradient-corrected linear filters (5x5)"},
    {DemosaicMethod::HamiltonAdams, "hamilton-adams", "ha",
     "Hamilton-Adams 1997 edge-directed green, colour-difference red/blue"},
    {DemosaicMethod::Lmmse, "lmmse", "",
     "Zhang-Wu 2005 directional LMMSE estimation of colour differences"},
    {DemosaicMethod::Mlri, "mlri", "",
     "Kiku-Monno-Tanaka-Okutomi 2014 minimized-Laplacian residual interpolation"},
};
}  // namespace

std::vector<std::string> demosaic_method_names() {
  std::vector<std::string> n;
  for (const auto& m : kMethods) n.push_back(m.name);
  return n;
}

std::vector<DemosaicMethod> all_demosaic_methods() {
  std::vector<DemosaicMethod> v;
  for (const auto& m : kMethods) v.push_back(m.method);
  return v;
}

const char* to_string(DemosaicMethod m) {
  for (const auto& i : kMethods)
    if (i.method == m) return i.name;
  return "?";
}

const char* demosaic_method_description(DemosaicMethod m) {
  for (const auto& i : kMethods)
    if (i.method == m) return i.description;
  return "?";
}

DemosaicMethod parse_demosaic_method(const std::string& name) {
  std::string l = name;
  std::transform(l.begin(), l.end(), l.begin(), [](unsigned char c) { return std::tolower(c); });
  for (const auto& m : kMethods)
    if (l == m.name || (*m.alias && l == m.alias)) return m.method;
  std::string known;
  for (const auto& m : kMethods)
    known += (known.empty() ? "" : ", ") + std::string(m.name) + (*m.alias ? std::string(" (") + m.alias + ")" : "");
  fail("unknown demosaic method '" + name + "' (known: " + known + ")");
}

ImageF demosaic(const ImageF& mosaic, CfaPattern pattern, DemosaicMethod method) {
  if (mosaic.channels() != 1) fail("demosaic: the mosaic must have exactly one channel");
  if (mosaic.empty()) fail("demosaic: the mosaic is empty");
  switch (method) {
    case DemosaicMethod::Bilinear: return demosaic_bilinear(mosaic, pattern);
    case DemosaicMethod::Malvar: return demosaic_malvar(mosaic, pattern);
    case DemosaicMethod::HamiltonAdams: return demosaic_hamilton_adams(mosaic, pattern);
    case DemosaicMethod::Lmmse: return demosaic_lmmse(mosaic, pattern);
    case DemosaicMethod::Mlri: return demosaic_mlri(mosaic, pattern);
  }
  internal_error("demosaic: unhandled method");
}

namespace {
// interleave_rgb's pixels [x0, x1) one at a time (the vector paths' heads and the row's tail).
inline void interleave_rgb_scalar(const float* r, const float* g, const float* b, float* rgb, int x0, int x1) {
  for (int x = x0; x < x1; ++x) {
    rgb[3 * x] = r[x];
    rgb[3 * x + 1] = g[x];
    rgb[3 * x + 2] = b[x];
  }
}
}  // namespace

#ifdef __x86_64__
namespace {
// interleave_rgb sixteen pixels (48 floats) at a time where the CPU has AVX-512: float i of the
// block is plane i mod 3 at pixel ⌊i/3⌋ (p <= 15), so each of its three output vectors is two
// two-source permutes (vpermt2ps): R and G into place (kRgbPerm.rg), then B (kRgbPerm.b, the
// lanes already placed taken through as they are). Copies only. Returns the pixels it wrote.
// From 64 pixels on, the stores are non-temporal (vmovntps), after a scalar run of x0 < 16
// pixels up to the output's first 64-byte boundary (12·x0 ≡ −address mod 64: as 3·11 ≡ 1 mod
// 16, x0 = 11·(−address/4) mod 16): the RGB frame is written once and not read here (the
// bilinear demosaic fused into the sense rows writes 24 MB a 2048x1024 frame), so its lines need
// not be read into the cache before they are overwritten, as demosaic_mlri's
// interleave_rgb_stream does. Measured on `expose` of the night bench frame (1 thread, best CPU
// time of 6 alternating runs of 20 calls): 45.0 -> 42.9 ms. An sfence orders the streamed
// stores before anything the caller does next.
struct RgbPerm {
  alignas(64) int32_t rg[3][16];
  alignas(64) int32_t b[3][16];
  RgbPerm() {
    for (int v = 0; v < 3; ++v)
      for (int l = 0; l < 16; ++l) {
        const int i = 16 * v + l, p = i / 3, c = i % 3;
        rg[v][l] = c == 1 ? 16 + p : p;  // c == 2: a placeholder the second permute replaces
        b[v][l] = c == 2 ? 16 + p : l;
      }
  }
};
const RgbPerm kRgbPerm;
// The widest level interleave_rgb takes: the machine's, capped by detail::interleave_rgb_max_isa (tests).
std::atomic<int> g_interleave_isa_cap{2};
__attribute__((target("avx512f")))
int interleave_rgb_avx512(const float* r, const float* g, const float* b, float* rgb, int n) {
  int x = 0;
  const uintptr_t a = reinterpret_cast<uintptr_t>(rgb);
  if (a % 4 == 0 && n >= 64) {
    const int x0 = static_cast<int>((11 * ((64 - a % 64) / 4)) % 16);  // 3·x0 ≡ −a/4 (mod 16)
    interleave_rgb_scalar(r, g, b, rgb, 0, x0);
    x = x0;
    for (; x + 16 <= n; x += 16) {
      const __m512 R = _mm512_loadu_ps(r + x), G = _mm512_loadu_ps(g + x), B = _mm512_loadu_ps(b + x);
      for (int v = 0; v < 3; ++v) {
        const __m512 rg = _mm512_permutex2var_ps(R, _mm512_load_si512(kRgbPerm.rg[v]), G);
        _mm512_stream_ps(rgb + 3 * x + 16 * v, _mm512_permutex2var_ps(rg, _mm512_load_si512(kRgbPerm.b[v]), B));
      }
    }
    _mm_sfence();
    return x;
  }
  for (; x + 16 <= n; x += 16) {
    const __m512 R = _mm512_loadu_ps(r + x), G = _mm512_loadu_ps(g + x), B = _mm512_loadu_ps(b + x);
    for (int v = 0; v < 3; ++v) {
      const __m512 rg = _mm512_permutex2var_ps(R, _mm512_load_si512(kRgbPerm.rg[v]), G);
      _mm512_storeu_ps(rgb + 3 * x + 16 * v, _mm512_permutex2var_ps(rg, _mm512_load_si512(kRgbPerm.b[v]), B));
    }
  }
  return x;
}
// The same eight pixels (24 floats) at a time where the CPU has AVX2 but not AVX-512: each of the
// three output vectors takes R, G and B moved into its lanes by one in-lane permute (vpermps)
// each and merged by two blends, output vector v's float k being plane (8v + k) mod 3 at pixel
// ⌊(8v + k)/3⌋. Copies only. From 64 pixels on, non-temporal stores (as the AVX-512 form, for
// the same reason) after a scalar run of x0 < 8 pixels up to the output's first 32-byte
// boundary (12·x0 ≡ −address mod 32: as 3·3 ≡ 1 mod 8, x0 = 3·(−address/4) mod 8); shorter
// rows take the SSE2 loop. Returns the pixels it wrote.
struct RgbPerm8 {
  alignas(32) int32_t p[3][3][8];  // [v][plane][k]: the pixel whose plane value lane k of output v takes
  RgbPerm8() {
    for (int v = 0; v < 3; ++v)
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k < 8; ++k) p[v][c][k] = (8 * v + k) % 3 == c ? (8 * v + k) / 3 : 0;
  }
};
const RgbPerm8 kRgbPerm8;
template <int V>
__attribute__((target("avx2"))) inline __m256 rgb_vector8(__m256 R, __m256 G, __m256 B) {
  // the blends' masks: the lanes k of output V whose float 8V + k is G ((8V + k) mod 3 = 1), B (= 2)
  const __m256 r = _mm256_permutevar8x32_ps(R, _mm256_load_si256(reinterpret_cast<const __m256i*>(kRgbPerm8.p[V][0])));
  const __m256 g = _mm256_permutevar8x32_ps(G, _mm256_load_si256(reinterpret_cast<const __m256i*>(kRgbPerm8.p[V][1])));
  const __m256 b = _mm256_permutevar8x32_ps(B, _mm256_load_si256(reinterpret_cast<const __m256i*>(kRgbPerm8.p[V][2])));
  constexpr int kG = V == 0 ? 0x92 : V == 1 ? 0x24 : 0x49, kB = V == 0 ? 0x24 : V == 1 ? 0x49 : 0x92;
  return _mm256_blend_ps(_mm256_blend_ps(r, g, kG), b, kB);
}
__attribute__((target("avx2")))
int interleave_rgb_avx2(const float* r, const float* g, const float* b, float* rgb, int n) {
  int x = 0;
  const uintptr_t a = reinterpret_cast<uintptr_t>(rgb);
  if (a % 4 != 0 || n < 64) return x;
  const int x0 = static_cast<int>((3 * ((32 - a % 32) / 4)) % 8);  // 3·x0 ≡ −a/4 (mod 8)
  interleave_rgb_scalar(r, g, b, rgb, 0, x0);
  x = x0;
  for (; x + 8 <= n; x += 8) {
    const __m256 R = _mm256_loadu_ps(r + x), G = _mm256_loadu_ps(g + x), B = _mm256_loadu_ps(b + x);
    _mm256_stream_ps(rgb + 3 * x, rgb_vector8<0>(R, G, B));
    _mm256_stream_ps(rgb + 3 * x + 8, rgb_vector8<1>(R, G, B));
    _mm256_stream_ps(rgb + 3 * x + 16, rgb_vector8<2>(R, G, B));
  }
  _mm_sfence();
  return x;
}

// The bilinear row's interior fused with the interleave where the CPU has AVX-512
// (detail::InteriorRow, for demosaic_bilinear_row): 16 pixels a step, their R, G and B formed in
// registers and interleaved by interleave_rgb_avx512's permutes, so the planar row is never
// stored and read back. Per pixel the same IEEE operations in the same order as BilinearKernel
// (lr = left + right, ud = up + down, diag = (up-left + up-right) + (down-left + down-right),
// ¼·(lr + ud), ¼·diag, ½·lr, ½·ud; RCCB's G = (C − R) − B as clear_to_rgb), no FMA: the lanes of
// one cell type take them by a mask blend, so the same bits as the pair loop then interleave_rgb
// (test SenseFused.EqualsTheUnfusedDefinition). Stores as interleave_rgb_avx512's: non-temporal
// from the first pixel whose output is 64-byte aligned; the pixels before it and those past the
// last whole step are one step each (from xs, and ending at xe), stored under a mask. Rows of
// fewer than 64 interior pixels, or an output not 4-byte aligned, take the pair loop.
// Returns the 16 pixels from x into v[0..2] (48 interleaved floats).
__attribute__((target("avx512f"), always_inline)) inline void bilinear_rgb16(const float* a, const float* c,
                                                                           const float* b, int x, bool red_row,
                                                                           __mmask16 even, bool clear, __m512 v[3]) {
  const __m512 quarter = _mm512_set1_ps(0.25f), half = _mm512_set1_ps(0.5f);
  const __m512 C = _mm512_loadu_ps(c + x);
  const __m512 lr = _mm512_add_ps(_mm512_loadu_ps(c + x - 1), _mm512_loadu_ps(c + x + 1));
  const __m512 ud = _mm512_add_ps(_mm512_loadu_ps(a + x), _mm512_loadu_ps(b + x));
  const __m512 diag = _mm512_add_ps(_mm512_add_ps(_mm512_loadu_ps(a + x - 1), _mm512_loadu_ps(a + x + 1)),
                                    _mm512_add_ps(_mm512_loadu_ps(b + x - 1), _mm512_loadu_ps(b + x + 1)));
  const __m512 g4 = _mm512_mul_ps(quarter, _mm512_add_ps(lr, ud)), o4 = _mm512_mul_ps(quarter, diag);
  const __m512 lr2 = _mm512_mul_ps(half, lr), ud2 = _mm512_mul_ps(half, ud);
  // even: the lanes of the red site's column parity (kR in a red row, kGb in a blue row); the
  // others kGr, kB. _mm512_mask_blend_ps(k, a, b): b where k is set.
  __m512 R, G, B;
  if (red_row) {
    R = _mm512_mask_blend_ps(even, lr2, C);
    G = _mm512_mask_blend_ps(even, C, g4);
    B = _mm512_mask_blend_ps(even, ud2, o4);
  } else {
    R = _mm512_mask_blend_ps(even, o4, ud2);
    G = _mm512_mask_blend_ps(even, g4, C);
    B = _mm512_mask_blend_ps(even, C, lr2);
  }
  if (clear) G = _mm512_sub_ps(_mm512_sub_ps(G, R), B);
  for (int k = 0; k < 3; ++k) {
    const __m512 rg = _mm512_permutex2var_ps(R, _mm512_load_si512(kRgbPerm.rg[k]), G);
    v[k] = _mm512_permutex2var_ps(rg, _mm512_load_si512(kRgbPerm.b[k]), B);
  }
}
// Floats [f0, f1) of the 48 in v stored to o (masked).
__attribute__((target("avx512f"), always_inline)) inline void store_floats48(float* o, const __m512 v[3], int f0,
                                                                           int f1) {
  for (int k = 0; k < 3; ++k) {
    const int lo = std::clamp(f0 - 16 * k, 0, 16), hi = std::clamp(f1 - 16 * k, 0, 16);
    const __mmask16 m = static_cast<__mmask16>(((1u << hi) - 1) & ~((1u << lo) - 1));
    _mm512_mask_storeu_ps(o + 16 * k, m, v[k]);
  }
}
__attribute__((target("avx512f")))
bool bilinear_interior_avx512(const float* a, const float* c, const float* b, bool red_row, int ox, bool clear,
                              int xs, int xe, float* o) {
  const uintptr_t addr = reinterpret_cast<uintptr_t>(o);
  if (addr % 4 != 0 || xe - xs < 64) return false;
  // The pixels whose 16-pixel step starts at x: even lanes where (x − ox) is even.
  auto even = [ox](int x) { return static_cast<__mmask16>(((x - ox) & 1) == 0 ? 0x5555 : 0xaaaa); };
  int x0 = static_cast<int>((11 * ((64 - addr % 64) / 4)) % 16);  // o + 3·x0 is 64-byte aligned
  while (x0 < xs) x0 += 16;
  __m512 v[3];
  if (x0 > xs) {  // pixels [xs, x0), fewer than 16: the step from xs
    bilinear_rgb16(a, c, b, xs, red_row, even(xs), clear, v);
    store_floats48(o + 3 * xs, v, 0, 3 * (x0 - xs));
  }
  int x = x0;
  for (; x + 16 <= xe; x += 16) {
    bilinear_rgb16(a, c, b, x, red_row, even(x), clear, v);
    for (int k = 0; k < 3; ++k) _mm512_stream_ps(o + 3 * x + 16 * k, v[k]);
  }
  if (x < xe) {  // pixels [x, xe), fewer than 16: the step ending at xe (its reads stay inside the row)
    bilinear_rgb16(a, c, b, xe - 16, red_row, even(xe - 16), clear, v);
    store_floats48(o + 3 * (xe - 16), v, 3 * (16 - (xe - x)), 48);
  }
  _mm_sfence();
  return true;
}

// The same fused pass where the CPU has AVX2 but not AVX-512 (or PHOTOSITE_MAX_ISA=avx2 caps it
// there): 8 pixels a step, R, G and B formed as bilinear_rgb16 does (the same adds and ¼/½
// scalings in the same order, no FMA; each lane takes its cell type's values by a blend, which
// copies) and interleaved by interleave_rgb_avx2's permutes and blends (rgb_vector8), so the
// same bits as the pair loop then interleave_rgb (test SenseFused.EqualsTheUnfusedDefinition,
// which runs it at the AVX2 level). Stores as interleave_rgb_avx2's: non-temporal from the first
// pixel whose output is 32-byte aligned; the pixels before it and those past the last whole step
// are one step each (from xs, and ending at xe), stored under a mask. Rows of fewer than 64
// interior pixels, or an output not 4-byte aligned, take the pair loop.
// Returns the 8 pixels from x into v[0..2] (24 interleaved floats). even: sign bit set in the
// lanes of the red site's column parity (_mm256_blendv_ps takes its second operand there).
__attribute__((target("avx2"), always_inline)) inline void bilinear_rgb8(const float* a, const float* c,
                                                                       const float* b, int x, bool red_row,
                                                                       __m256 even, bool clear, __m256 v[3]) {
  const __m256 quarter = _mm256_set1_ps(0.25f), half = _mm256_set1_ps(0.5f);
  const __m256 C = _mm256_loadu_ps(c + x);
  const __m256 lr = _mm256_add_ps(_mm256_loadu_ps(c + x - 1), _mm256_loadu_ps(c + x + 1));
  const __m256 ud = _mm256_add_ps(_mm256_loadu_ps(a + x), _mm256_loadu_ps(b + x));
  const __m256 diag = _mm256_add_ps(_mm256_add_ps(_mm256_loadu_ps(a + x - 1), _mm256_loadu_ps(a + x + 1)),
                                    _mm256_add_ps(_mm256_loadu_ps(b + x - 1), _mm256_loadu_ps(b + x + 1)));
  const __m256 g4 = _mm256_mul_ps(quarter, _mm256_add_ps(lr, ud)), o4 = _mm256_mul_ps(quarter, diag);
  const __m256 lr2 = _mm256_mul_ps(half, lr), ud2 = _mm256_mul_ps(half, ud);
  __m256 R, G, B;
  if (red_row) {
    R = _mm256_blendv_ps(lr2, C, even);
    G = _mm256_blendv_ps(C, g4, even);
    B = _mm256_blendv_ps(ud2, o4, even);
  } else {
    R = _mm256_blendv_ps(o4, ud2, even);
    G = _mm256_blendv_ps(g4, C, even);
    B = _mm256_blendv_ps(C, lr2, even);
  }
  if (clear) G = _mm256_sub_ps(_mm256_sub_ps(G, R), B);
  v[0] = rgb_vector8<0>(R, G, B);
  v[1] = rgb_vector8<1>(R, G, B);
  v[2] = rgb_vector8<2>(R, G, B);
}
// Floats [f0, f1) of the 24 in v stored to o (masked).
__attribute__((target("avx2"), always_inline)) inline void store_floats24(float* o, const __m256 v[3], int f0,
                                                                        int f1) {
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  for (int k = 0; k < 3; ++k) {
    const __m256i i = _mm256_add_epi32(lane, _mm256_set1_epi32(8 * k));
    // f0 <= i < f1: (i > f0 - 1) and (f1 > i)
    const __m256i m = _mm256_and_si256(_mm256_cmpgt_epi32(i, _mm256_set1_epi32(f0 - 1)),
                                       _mm256_cmpgt_epi32(_mm256_set1_epi32(f1), i));
    _mm256_maskstore_ps(o + 8 * k, m, v[k]);
  }
}
__attribute__((target("avx2")))
bool bilinear_interior_avx2(const float* a, const float* c, const float* b, bool red_row, int ox, bool clear,
                            int xs, int xe, float* o) {
  const uintptr_t addr = reinterpret_cast<uintptr_t>(o);
  if (addr % 4 != 0 || xe - xs < 64) return false;
  // The red site's column parity in a step from x: the even lanes where (x − ox) is even.
  const __m256 parity[2] = {_mm256_castsi256_ps(_mm256_setr_epi32(-1, 0, -1, 0, -1, 0, -1, 0)),
                            _mm256_castsi256_ps(_mm256_setr_epi32(0, -1, 0, -1, 0, -1, 0, -1))};
  auto odd = [ox](int x) { return (x - ox) & 1; };  // parity[odd(x)]: the mask of a step from x
  int x0 = static_cast<int>((3 * ((32 - addr % 32) / 4)) % 8);  // o + 3·x0 is 32-byte aligned
  while (x0 < xs) x0 += 8;
  __m256 v[3];
  if (x0 > xs) {  // pixels [xs, x0), fewer than 8: the step from xs
    bilinear_rgb8(a, c, b, xs, red_row, parity[odd(xs)], clear, v);
    store_floats24(o + 3 * xs, v, 0, 3 * (x0 - xs));
  }
  int x = x0;
  const __m256 even_x0 = parity[odd(x0)];  // every step of the loop starts at x0's parity
  for (; x + 8 <= xe; x += 8) {
    bilinear_rgb8(a, c, b, x, red_row, even_x0, clear, v);
    for (int k = 0; k < 3; ++k) _mm256_stream_ps(o + 3 * x + 8 * k, v[k]);
  }
  if (x < xe) {  // pixels [x, xe), fewer than 8: the step ending at xe (its reads stay inside the row)
    bilinear_rgb8(a, c, b, xe - 8, red_row, parity[odd(xe - 8)], clear, v);
    store_floats24(o + 3 * (xe - 8), v, 3 * (8 - (xe - x)), 24);
  }
  _mm_sfence();
  return true;
}
}  // namespace
#endif

#ifdef __x86_64__
void detail::interleave_rgb_max_isa(int isa) { g_interleave_isa_cap.store(std::clamp(isa, 0, 2)); }
#else
void detail::interleave_rgb_max_isa(int) {}
#endif

void interleave_rgb(const float* r, const float* g, const float* b, float* rgb, int n) {
  int x = 0;
#ifdef __x86_64__
  const int isa = std::min(detail::machine_isa_level(), g_interleave_isa_cap.load(std::memory_order_relaxed));
  if (isa >= 2) x = interleave_rgb_avx512(r, g, b, rgb, n);
  else if (isa == 1) x = interleave_rgb_avx2(r, g, b, rgb, n);
#endif
#ifdef __SSE2__
  // Four pixels per step: (r0 g0 b0 r1) (g1 b1 r2 g2) (b2 r3 g3 b3).
  for (; x + 4 <= n; x += 4) {
    const __m128 R = _mm_loadu_ps(r + x), G = _mm_loadu_ps(g + x), B = _mm_loadu_ps(b + x);
    const __m128 rg = _mm_unpacklo_ps(R, G);                         // r0 g0 r1 g1
    const __m128 b0r1 = _mm_shuffle_ps(B, R, _MM_SHUFFLE(1, 1, 0, 0));  // b0 b0 r1 r1
    const __m128 o0 = _mm_shuffle_ps(rg, b0r1, _MM_SHUFFLE(2, 0, 1, 0));
    const __m128 g1b1 = _mm_shuffle_ps(G, B, _MM_SHUFFLE(1, 1, 1, 1));  // g1 g1 b1 b1
    const __m128 r2g2 = _mm_shuffle_ps(R, G, _MM_SHUFFLE(2, 2, 2, 2));  // r2 r2 g2 g2
    const __m128 o1 = _mm_shuffle_ps(g1b1, r2g2, _MM_SHUFFLE(2, 0, 2, 0));
    const __m128 b2r3 = _mm_shuffle_ps(B, R, _MM_SHUFFLE(3, 3, 2, 2));  // b2 b2 r3 r3
    const __m128 g3b3 = _mm_shuffle_ps(G, B, _MM_SHUFFLE(3, 3, 3, 3));  // g3 g3 b3 b3
    const __m128 o2 = _mm_shuffle_ps(b2r3, g3b3, _MM_SHUFFLE(2, 0, 2, 0));
    _mm_storeu_ps(rgb + 3 * x, o0);
    _mm_storeu_ps(rgb + 3 * x + 4, o1);
    _mm_storeu_ps(rgb + 3 * x + 8, o2);
  }
#endif
  interleave_rgb_scalar(r, g, b, rgb, x, n);
}

void filter_planes_to_rgb(CfaPattern pattern, const float planes[4], float rgb[3]) {
  switch (pattern) {
    case CfaPattern::RCCB:
      rgb[0] = planes[0];
      rgb[2] = planes[2];
      rgb[1] = planes[3] - planes[0] - planes[2];
      break;
    case CfaPattern::RCCC:
      rgb[0] = planes[0];
      rgb[1] = rgb[2] = 0.5f * (planes[3] - planes[0]);
      break;
    case CfaPattern::Mono:
      rgb[0] = rgb[1] = rgb[2] = planes[3] / 3.f;
      break;
    default:
      rgb[0] = planes[0];
      rgb[1] = planes[1];
      rgb[2] = planes[2];
  }
}

size_t neutralize_at_white_level(ImageF& rgb, const ImageF& mosaic, CfaPattern pattern, double white_level,
                                 double stored_offset, double stored_scale, bool integer_codes) {
  const double level = (white_level - stored_offset) * stored_scale;
  const double at = integer_codes ? (white_level - 0.5 - stored_offset) * stored_scale : level;
  return neutralize_clipped_highlights(rgb, mosaic, pattern, static_cast<float>(at), static_cast<float>(level / 3));
}

size_t neutralize_clipped_highlights(ImageF& rgb, const ImageF& mosaic, CfaPattern pattern, float clipped_at,
                                     float neutral) {
  if (!is_clear_pattern(pattern)) return 0;
  const int w = mosaic.width(), h = mosaic.height();
  if (mosaic.channels() != 1 || rgb.channels() != 3 || !rgb.same_shape(w, h))
    internal_error("neutralize_clipped_highlights: rgb must be the 3-channel image of the 1-channel mosaic");
  // Rows holding a clipped sample; most frames have none, and are left as they are.
  std::vector<uint8_t> row_clipped(static_cast<size_t>(h));
  bool any = false;
#pragma omp parallel for schedule(static) reduction(|| : any)
  for (int y = 0; y < h; ++y) {
    const float* m = mosaic.row(y);
    bool c = false;
    for (int x = 0; x < w; ++x) c = c || m[x] >= clipped_at;
    row_clipped[y] = c;
    any = any || c;
  }
  if (!any) return 0;
  size_t n = 0;
#pragma omp parallel reduction(+ : n)
  {
    std::vector<uint8_t> col(static_cast<size_t>(w));  // column x holds a clipped sample in rows y-1..y+1
#pragma omp for schedule(static)
    for (int y = 0; y < h; ++y) {
      const int y0 = std::max(0, y - 1), y1 = std::min(h - 1, y + 1);
      bool near = false;
      for (int yy = y0; yy <= y1; ++yy) near = near || row_clipped[yy];
      if (!near) continue;
      std::fill(col.begin(), col.end(), uint8_t{0});
      for (int yy = y0; yy <= y1; ++yy) {
        const float* m = mosaic.row(yy);
        for (int x = 0; x < w; ++x) col[x] |= m[x] >= clipped_at;
      }
      float* o = rgb.row(y);
      for (int x = 0; x < w; ++x) {
        if (!(col[x] | (x > 0 && col[x - 1]) | (x + 1 < w && col[x + 1]))) continue;
        o[3 * x] = o[3 * x + 1] = o[3 * x + 2] = neutral;
        ++n;
      }
    }
  }
  return n;
}

// Normalized convolution with [1 2 1; 2 4 2; 1 2 1] over the pixels of each filter colour: any
// pattern, borders use only the neighbours that exist. The path for RCCC, Mono and images too
// small for the mirrored Bayer path.
ImageF detail::demosaic_bilinear_generic(const ImageF& m, CfaPattern pattern) {
  const int w = m.width(), h = m.height();
  ImageF out(w, h, 3, uninitialized, m.unit());
  static constexpr float k[3][3] = {{1, 2, 1}, {2, 4, 2}, {1, 2, 1}};
#pragma omp parallel for schedule(static)
  for (int y = 0; y < h; ++y) {
    float* o = out.row(y);
    for (int x = 0; x < w; ++x) {
      float sum[4] = {0, 0, 0, 0}, wsum[4] = {0, 0, 0, 0};
      for (int dy = -1; dy <= 1; ++dy) {
        const int yy = y + dy;
        if (yy < 0 || yy >= h) continue;
        const float* r = m.row(yy);
        for (int dx = -1; dx <= 1; ++dx) {
          const int xx = x + dx;
          if (xx < 0 || xx >= w) continue;
          const int c = static_cast<int>(cfa_color(pattern, xx, yy));
          const float kw = k[dy + 1][dx + 1];
          sum[c] += kw * r[xx];
          wsum[c] += kw;
        }
      }
      float planes[4];
      for (int c = 0; c < 4; ++c) planes[c] = wsum[c] > 0 ? sum[c] / wsum[c] : 0.f;
      filter_planes_to_rgb(pattern, planes, o + 3 * x);
    }
  }
  return out;
}

namespace {
// Bilinear on RGGB: each missing colour is the mean of its nearest 2 or 4 samples.
struct BilinearKernel {
  static constexpr int kOut = 3;
  template <int T, class F>
  void px(const F& f, const detail::PixelOut& o) const {
    using namespace detail;
    const float c = f(0, 0, 0);
    const float lr = f(0, -1, 0) + f(0, 1, 0), ud = f(0, 0, -1) + f(0, 0, 1);
    if constexpr (T == kR || T == kB) {
      const float diag = (f(0, -1, -1) + f(0, 1, -1)) + (f(0, -1, 1) + f(0, 1, 1));
      const float other = 0.25f * diag, g = 0.25f * (lr + ud);
      o[0] = T == kR ? c : other;
      o[1] = g;
      o[2] = T == kR ? other : c;
    } else {
      o[0] = 0.5f * (T == kGr ? lr : ud);
      o[1] = c;
      o[2] = 0.5f * (T == kGr ? ud : lr);
    }
  }
};

}  // namespace

ImageF demosaic_bilinear(const ImageF& m, CfaPattern pattern) {
  if (!detail::bayer_path_ok(m, pattern)) return detail::demosaic_bilinear_generic(m, pattern);
  const auto ph = detail::bayer_phase(pattern);
  ImageF out(m.width(), m.height(), 3, uninitialized, m.unit());
  const ImageF* planes[1] = {&m};
  detail::run_stencil<1>(planes, ph, out, BilinearKernel{}, ph.clear);
  return out;
}

// The clear sites of a row: cell types kGr and kGb, the columns of the other parity than the
// row's red or blue site.
static int first_clear_column(const detail::BayerPhase& ph, int y) { return (ph.ox + y - ph.oy + 1) & 1; }

detail::GreenLevelMosaic::GreenLevelMosaic(const ImageF& m, const BayerPhase& ph) : m_(m), ph_(ph) {
  if (!ph.clear) return;
  const int w = m.width(), h = m.height();
  scaled_ = ImageF(w, h, 1, uninitialized, m.unit());
#pragma omp parallel for schedule(static)
  for (int y = 0; y < h; ++y) {
    const float* src = m.row(y);
    float* dst = scaled_.row(y);
    std::copy(src, src + w, dst);
    for (int x = first_clear_column(ph, y); x < w; x += 2) dst[x] = shader::clear_to_green_level(src[x]);
  }
}

void detail::GreenLevelMosaic::finish(ImageF& rgb) const {
  if (!ph_.clear) return;
  const int w = m_.width(), h = m_.height();
#pragma omp parallel for schedule(static)
  for (int y = 0; y < h; ++y) {
    const float* c = m_.row(y);
    float* o = rgb.row(y);
    const int xc = first_clear_column(ph_, y);
    for (int x = 0; x < w; ++x)
      o[3 * x + 1] = shader::rccb_green(((x ^ xc) & 1) == 0, c[x], o[3 * x + 1], o[3 * x], o[3 * x + 2]);
  }
}

bool detail::bilinear_row_path(int w, int h, CfaPattern pattern) { return bayer_path_ok(w, h, pattern); }

// With an AVX2 clone (flatten: the row code inlined into each clone): the pair loop's adds and
// quarter/half scalings are the same IEEE operations per pixel at any vector width (no FMA:
// -ffp-contract=off), so the same bits as demosaic_bilinear's SSE2 build (test
// SenseFused.EqualsTheUnfusedDefinition). Where the CPU has AVX-512 the interior is
// bilinear_interior_avx512 (the pair loop and the interleave in one pass, the same operations):
// `bench sense` on the AMD EPYC Zen 4, 1 thread, four alternating pairs (2026-11-30): `sense`
// 18.88, 18.34, 18.51, 18.35 -> 17.55, 17.94, 17.30, 17.56 ms CPU (docs/benchmarks.md). Where
// it has AVX2 but not AVX-512, bilinear_interior_avx2 (8 pixels a step): at PHOTOSITE_MAX_ISA=avx2
// on the Zen 4, `bench night --threads 1 --cpu-clock`, six alternating rounds (2026-11-30):
// `cpu: sensor (expose)` median 27.69 -> 27.16 ms, lower in 5 of 6 ("Twenty-sixth session: the
// sensor's AVX2 rows", docs/benchmarks.md). The whole-image demosaic_bilinear (the `demosaic`
// command) keeps the two loops.
__attribute__((flatten, target_clones("avx2", "default")))
void detail::demosaic_bilinear_row(CfaPattern pattern, const float* above, const float* centre, const float* below,
                                   int y, int w, int h, float* rgb_row, float* planar) {
  const auto ph = bayer_phase(pattern);
  const float* const rows[1][3] = {{above, centre, below}};
  // The interior fused with the interleave where the CPU has AVX-512 or AVX2 and interleave_rgb
  // may take that level (its level, capped by detail::interleave_rgb_max_isa in the tests).
  InteriorRow interior = nullptr;
#ifdef __x86_64__
  const int isa = std::min(machine_isa_level(), g_interleave_isa_cap.load(std::memory_order_relaxed));
  if (isa >= 2) interior = bilinear_interior_avx512;
  else if (isa == 1) interior = bilinear_interior_avx2;
#endif
  if (ph.clear) stencil_row<true, 1, 1>(BilinearKernel{}, ph, rows, y, w, h, rgb_row, planar, interior);
  else stencil_row<false, 1, 1>(BilinearKernel{}, ph, rows, y, w, h, rgb_row, planar, interior);
}

}  // namespace photosite
