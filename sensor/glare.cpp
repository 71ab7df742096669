// Lens veiling glare: the reduced-resolution pyramid of include/photosite/sensor/glare.h.
// Every float operation below is written in a fixed order (no FMA: -ffp-contract=off), the
// same order as kernels/glare_*.comp and photon.comp; the borders, taps, bilinear steps and the
// mix are the same functions (kernels/common/glare.glsl), so both backends give the same bits. Rows are independent and the energy sums run in a fixed order, so the thread
// count never changes a result.
#include "photosite/sensor/glare.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <immintrin.h>
#include <memory>
#include <string>
#include <utility>

#include "core/isa_detail.h"
#include "photosite/error.h"
#include "photosite/units.h"
#include "sensor/glare_detail.h"

namespace photosite {

namespace {
constexpr int kMaxLevel = 16;

// The pyramid's borders, taps, steps and mix are kernels/common/glare.glsl's, shared with the
// Vulkan kernels (sensor/glare_detail.h).
using shader::glare_lerp;
using shader::glare_mirror;
using shader::glare_up_tap;
using UpTap = shader::GlareTap;

// The row kernels below carry AVX-512 and AVX2 clones (target_clones): the same IEEE operations
// in the same order per sample on every clone (no FMA: -ffp-contract=off, and neither target
// has fma), so the same bits; the default clone is the SSE2 baseline the library is built for.

// One row of the bilinear 2x upsampling along x: u[3x + c] = w0·t[3·i0 + c] + w1·t[3·i1 + c]
// with glare_up_tap's taps, for x < width; t holds cw pixels; e, o: scratch of 3·cw floats
// each. The interior pairs (x = 2j, 2j + 1) need no clamping: their even and odd samples
// e[k] = ¼·t[k − 3] + ¾·t[k], o[k] = ¾·t[k] + ¼·t[k + 3] (glare_up_tap's arithmetic) are formed
// first over the contiguous row, where they vectorize, then interleaved pixel by pixel.
//
// Where the CPU has AVX-512, the interior is formed eight pixel pairs (48 floats of u) at a time
// in registers, e and o never stored (upsample_pairs_avx512): float i of the block of pairs
// j0 .. j0 + 7 is channel c = r mod 3 of pair q = ⌊i/6⌋'s even (r = i mod 6 < 3) or odd pixel,
// glare_lerp(w0, X, w1, Y) with X = t[3(j0 + q − 1) + c], Y = t[3(j0 + q) + c], (w0, w1) = (¼, ¾)
// when even, and X = t[3(j0 + q) + c], Y = t[3(j0 + q + 1) + c], (¾, ¼) when odd: e's and o's
// operations on the same operands, so the same bits. X and Y of each output vector come from
// the 32 floats of t from 3(j0 − 1) (offsets up to 3·7 + 6 + 2 = 29) by one two-source permute
// each (kUpPairIndex). Returns the first pair it left.
const bool kGlareAvx512 = photosite::detail::have_avx512();
const bool kGlareAvx2 = photosite::detail::have_avx2();  // upsample_pairs_avx2, level1_row_sums_avx2, ...
struct UpPairIndex {
  alignas(64) int32_t x[3][16], y[3][16];
  alignas(64) float w0[3][16], w1[3][16];
  UpPairIndex() {
    for (int v = 0; v < 3; ++v)
      for (int l = 0; l < 16; ++l) {
        const int i = 16 * v + l, q = i / 6, r = i % 6, odd = r >= 3 ? 1 : 0, c = r % 3;
        x[v][l] = 3 * (q + odd) + c;
        y[v][l] = 3 * (q + 1 + odd) + c;
        w0[v][l] = odd ? 0.75f : 0.25f;
        w1[v][l] = odd ? 0.25f : 0.75f;
      }
  }
};
const UpPairIndex kUpPairIndex;
// Output vector v of the block whose window of t is ta, tb.
__attribute__((target("avx512f"))) inline __m512 up_pair_vector(__m512 ta, __m512 tb, int v) {
  const UpPairIndex& ix = kUpPairIndex;
  const __m512 X = _mm512_permutex2var_ps(ta, _mm512_load_si512(ix.x[v]), tb);
  const __m512 Y = _mm512_permutex2var_ps(ta, _mm512_load_si512(ix.y[v]), tb);
  return _mm512_add_ps(_mm512_mul_ps(_mm512_load_ps(ix.w0[v]), X), _mm512_mul_ps(_mm512_load_ps(ix.w1[v]), Y));
}
// Pairs j0 .. j0 + 7 are interior (j0 + 7 <= cw − 2) and the window t[3(j0 − 1), +32) lies
// inside t's 3·cw floats while j0 + 10 <= cw.
inline bool up_pairs_fit(int j0, int cw) { return j0 + 10 <= cw; }
__attribute__((target("avx512f")))
int upsample_pairs_avx512(const float* t, int cw, float* u) {
  int j0 = 1;
  for (; up_pairs_fit(j0, cw); j0 += 8) {
    const float* tw = t + 3 * (j0 - 1);
    const __m512 ta = _mm512_loadu_ps(tw), tb = _mm512_loadu_ps(tw + 16);
    for (int v = 0; v < 3; ++v) _mm512_storeu_ps(u + 6 * j0 + 16 * v, up_pair_vector(ta, tb, v));
  }
  return j0;
}
// glare_row's interior where the CPU has AVX-512: the same blocks of pairs, each output vector
// mixed at once, out = glare_mix(keep, in, s_c, u) = keep·in + s_c·u (the channel's scale per
// lane), so the upsampled row u is never stored. Returns the first pair it left.
__attribute__((target("avx512f")))
int upsample_mix_pairs_avx512(const float* t, int cw, float keep, const float* s3, const float* in, float* out) {
  alignas(64) float sl[3][16];
  for (int v = 0; v < 3; ++v)
    for (int l = 0; l < 16; ++l) sl[v][l] = s3[(16 * v + l) % 3];
  const __m512 vkeep = _mm512_set1_ps(keep);
  int j0 = 1;
  for (; up_pairs_fit(j0, cw); j0 += 8) {
    const float* tw = t + 3 * (j0 - 1);
    const __m512 ta = _mm512_loadu_ps(tw), tb = _mm512_loadu_ps(tw + 16);
    for (int v = 0; v < 3; ++v) {
      const size_t k = 6 * static_cast<size_t>(j0) + 16 * v;
      _mm512_storeu_ps(out + k, _mm512_add_ps(_mm512_mul_ps(vkeep, _mm512_loadu_ps(in + k)),
                                              _mm512_mul_ps(_mm512_load_ps(sl[v]), up_pair_vector(ta, tb, v))));
    }
  }
  return j0;
}

// The same interior on AVX2 (no two-source permute): four pixel pairs (24 floats of u, three
// vectors) at a time. Output vector v's X operands lie within 8 consecutive floats of the window
// t[3(j0 − 1), +20), from offset kUpPair8Base[v] (X = 3(q + odd) + c spans 0..5, 5..9, 9..14 for
// v = 0, 1, 2), so one unaligned load and one permute across the vector (vpermps) give them; Y = X + 3
// (the next tap, 3 floats on), the same permute of the load 3 floats on. Then w0·X + w1·Y, the
// operations of glare_lerp and of upsample_pairs_avx512 per float, so the same bits
// (GlareFastPath.SkirtEqualsTheWholeImageDefinition, at each cap by IsaCaps.FastPathTestsPassAtEachCap).
// Pairs j0 .. j0 + 3 are interior (j0 + 3 <= cw − 2) and the window's last float, offset
// 9 + 3 + 7 = 19, lies inside t's 3·cw floats (3(j0 − 1) + 19 < 3cw) while j0 + 6 <= cw.
// Returns the first pair it left. Where upsample_row formed e and o over the row and interleaved
// them: `photosite bench sense` at PHOTOSITE_MAX_ISA=avx2, 1 thread, "photon stage alone (with the
// lens glare)" 7.20 -> 6.78 ms, medians (docs/benchmarks.md, "Twenty-seventh session: the sensor's
// AVX2 gap").
constexpr int kUpPair8Base[3] = {0, 5, 9};
struct UpPair8Index {
  alignas(32) int32_t x[3][8];
  alignas(32) float w0[3][8], w1[3][8];
  UpPair8Index() {
    for (int v = 0; v < 3; ++v)
      for (int l = 0; l < 8; ++l) {
        const int i = 8 * v + l, q = i / 6, r = i % 6, odd = r >= 3 ? 1 : 0, c = r % 3;
        x[v][l] = 3 * (q + odd) + c - kUpPair8Base[v];
        w0[v][l] = odd ? 0.75f : 0.25f;
        w1[v][l] = odd ? 0.25f : 0.75f;
      }
  }
};
const UpPair8Index kUpPair8Index;
__attribute__((target("avx2")))
int upsample_pairs_avx2(const float* t, int cw, float* u) {
  const UpPair8Index& ix = kUpPair8Index;
  __m256i idx[3];
  __m256 w0[3], w1[3];
  for (int v = 0; v < 3; ++v) {
    idx[v] = _mm256_load_si256(reinterpret_cast<const __m256i*>(ix.x[v]));
    w0[v] = _mm256_load_ps(ix.w0[v]);
    w1[v] = _mm256_load_ps(ix.w1[v]);
  }
  int j0 = 1;
  for (; j0 + 6 <= cw; j0 += 4) {
    const float* tw = t + 3 * (j0 - 1);
    for (int v = 0; v < 3; ++v) {
      const __m256 X = _mm256_permutevar8x32_ps(_mm256_loadu_ps(tw + kUpPair8Base[v]), idx[v]);
      const __m256 Y = _mm256_permutevar8x32_ps(_mm256_loadu_ps(tw + kUpPair8Base[v] + 3), idx[v]);
      _mm256_storeu_ps(u + 6 * j0 + 8 * v, _mm256_add_ps(_mm256_mul_ps(w0[v], X), _mm256_mul_ps(w1[v], Y)));
    }
  }
  return j0;
}

PHOTOSITE_TARGET_CLONES
void upsample_row(const float* __restrict t, int cw, int width, float* __restrict u, float* __restrict e,
                  float* __restrict o) {
  auto one = [&](int x) { detail::glare_up_pixel(t, cw, x, u + 3 * x); };
  if (cw < 3) {
    for (int x = 0; x < width; ++x) one(x);
    return;
  }
  one(0);
  one(1);
  const int k_end = 3 * (cw - 1);  // x = 2j and 2j + 1 for 1 <= j < cw − 1, below 2cw − 2 <= width
  // pairs below k0/3 done
  const int k0 = 3 * (kGlareAvx512 ? upsample_pairs_avx512(t, cw, u) : kGlareAvx2 ? upsample_pairs_avx2(t, cw, u) : 1);
  for (int k = k0; k < k_end; ++k) {
    e[k] = glare_lerp(0.25f, t[k - 3], 0.75f, t[k]);
    o[k] = glare_lerp(0.75f, t[k], 0.25f, t[k + 3]);
  }
  // Interleaved by 4-float stores that overlap: e[k..k+3] to u[2k..], then o[k..k+3] to u[2k+3..]
  // over e's fourth float, whose own fourth float the next pixel pair (or one(), past the
  // interior) overwrites in turn. e, o hold 3·cw floats, so the reads stay inside them.
  for (int k = k0; k < k_end; k += 3) {
    _mm_storeu_ps(u + 2 * k, _mm_loadu_ps(e + k));
    _mm_storeu_ps(u + 2 * k + 3, _mm_loadu_ps(o + k));
  }
  for (int x = 2 * (cw - 1); x < width; ++x) one(x);
}

// out[j] = glare_lerp(w0, a[j], w1, b[j]) over n samples (the vertical bilinear step).
PHOTOSITE_TARGET_CLONES
void lerp_row(float w0, const float* __restrict a, float w1, const float* __restrict b, size_t n,
              float* __restrict out) {
  for (size_t j = 0; j < n; ++j) out[j] = glare_lerp(w0, a[j], w1, b[j]);
}

// The 2R + 1 = 7 taps of a blur over n samples in one pass: a = Σ_k g_k·p_k[j], summed from 0
// in the order k = 0 .. 6 (a = 0; a = a + g_k·p_k[j]: the order of the blur's definition, term
// by term), then o[j] = a (weigh false), or o[j] = w·a + u[j] (u given) or w·a (u null): a
// level's weighted blur plus the upsampled coarser accumulator. The same IEEE operations in the
// same order per sample as forming the sum tap by tap over the row, without storing and
// reloading it between taps.
static_assert(kGlareBlurRadius == 3, "blur_taps is written for 7 taps");
PHOTOSITE_TARGET_CLONES
void blur_taps(const float* const* p, const float* gk, size_t n, bool weigh, float w, const float* __restrict u,
               float* __restrict o) {
  const float* __restrict p0 = p[0];
  const float* __restrict p1 = p[1];
  const float* __restrict p2 = p[2];
  const float* __restrict p3 = p[3];
  const float* __restrict p4 = p[4];
  const float* __restrict p5 = p[5];
  const float* __restrict p6 = p[6];
  const float g0 = gk[0], g1 = gk[1], g2 = gk[2], g3 = gk[3], g4 = gk[4], g5 = gk[5], g6 = gk[6];
  auto sum = [&](size_t j) {
    float a = 0.f;
    a = a + g0 * p0[j];
    a = a + g1 * p1[j];
    a = a + g2 * p2[j];
    a = a + g3 * p3[j];
    a = a + g4 * p4[j];
    a = a + g5 * p5[j];
    a = a + g6 * p6[j];
    return a;
  };
  if (!weigh)
    for (size_t j = 0; j < n; ++j) o[j] = sum(j);
  else if (u)
    for (size_t j = 0; j < n; ++j) o[j] = w * sum(j) + u[j];
  else
    for (size_t j = 0; j < n; ++j) o[j] = w * sum(j);
}
// g_|k| for k = −R .. R.
std::array<float, 2 * kGlareBlurRadius + 1> blur_weights(const std::array<float, kGlareBlurRadius + 1>& g) {
  std::array<float, 2 * kGlareBlurRadius + 1> gk{};
  for (int k = -kGlareBlurRadius; k <= kGlareBlurRadius; ++k) gk[k + kGlareBlurRadius] = g[std::abs(k)];
  return gk;
}

// out[3x + c] = glare_mix(keep, in[3x + c], s_c, u[3x + c]) over n = 3·width samples, in blocks
// of 24 (8 pixels: a whole number of vectors and of pixels) with the scales laid out per lane.
PHOTOSITE_TARGET_CLONES
void mix_row(float keep, const float* s3, const float* __restrict in, const float* __restrict u, size_t n,
             float* __restrict out) {
  float sl[24];
  for (int i = 0; i < 24; ++i) sl[i] = s3[i % 3];
  size_t k = 0;
  for (; k + 24 <= n; k += 24)
    for (int i = 0; i < 24; ++i) out[k + i] = shader::glare_mix(keep, in[k + i], sl[i], u[k + i]);
  for (; k < n; ++k) out[k] = shader::glare_mix(keep, in[k], sl[k % 24], u[k]);
}

// Σ_j n_x(j)·v over one level-1 row (n = number of full-resolution children), per channel, in
// double and in order: the row sums behind glare_level1_energy.
inline std::array<double, 3> level1_row_sum(const float* r, int w, int full_width) {
  double s0 = 0, s1 = 0, s2 = 0;
  for (int j = 0; j < w; ++j) {
    const double n = 2 * j + 1 < full_width ? 2.0 : 1.0;
    s0 += n * static_cast<double>(r[3 * j]);
    s1 += n * static_cast<double>(r[3 * j + 1]);
    s2 += n * static_cast<double>(r[3 * j + 2]);
  }
  return {s0, s1, s2};
}
// level1_row_sum of nr <= 8 rows r[0 .. nr) at once, into out[0 .. nr): each row's three sums
// in its own order, so the same sums. The scalar sum is a chain of dependent double adds (about
// 4 cycles each: a 1024-pixel row waits ~4,000 cycles on it, which the profile showed as half of
// accumulate's and down2_then_1331's time); eight rows give eight independent chains. Where the
// CPU has AVX2, one 4-double vector per row holds (s0, s1, s2, −): pixel j adds
// n·(r[3j], r[3j + 1], r[3j + 2], r[3j + 3]) (a 4-float load; the fourth float, the next
// pixel's, lands in the unused lane), n = 2 for every j < w − 1 (2j + 1 <= 2w − 3 < full_width,
// full_width >= 2w − 1); the last pixel, its n and its three floats, by the scalar step after.
// Per lane the scalar code's IEEE operations (double(v), n·v, s + n·v) in its order: the same bits
// (test GlareFastPath.Level1RowSumsEqualTheRowByRowSums).
__attribute__((target("avx2")))
void level1_row_sums_avx2(const float* const* r, int nr, int w, int full_width, std::array<double, 3>* out) {
  constexpr int N = 8;
  const float* row[N];
  for (int i = 0; i < N; ++i) row[i] = r[i < nr ? i : 0];  // rows past nr repeat row 0, unused
  __m256d acc[N];
  for (int i = 0; i < N; ++i) acc[i] = _mm256_setzero_pd();
  const __m256d two = _mm256_set1_pd(2.0);
  for (int j = 0; j + 1 < w; ++j)
#pragma GCC unroll 8
    for (int i = 0; i < N; ++i)
      acc[i] = _mm256_add_pd(acc[i], _mm256_mul_pd(two, _mm256_cvtps_pd(_mm_loadu_ps(row[i] + 3 * j))));
  const int j = w - 1;
  const double n = 2 * j + 1 < full_width ? 2.0 : 1.0;
  for (int i = 0; i < nr; ++i) {
    alignas(32) double s[4];
    _mm256_store_pd(s, acc[i]);
    for (int c = 0; c < 3; ++c) out[i][c] = s[c] + n * static_cast<double>(row[i][3 * j + c]);
  }
}
void level1_row_sums(const float* const* r, int nr, int w, int full_width, std::array<double, 3>* out) {
  if (kGlareAvx2 && w >= 1) {
    level1_row_sums_avx2(r, nr, w, full_width, out);
    return;
  }
  for (int i = 0; i < nr; ++i) out[i] = level1_row_sum(r[i], w, full_width);
}
constexpr int kRowSumBatch = 8;
std::array<double, 3> combine_rows(const std::vector<std::array<double, 3>>& rows, int full_height) {
  std::array<double, 3> e{0, 0, 0};
  for (size_t i = 0; i < rows.size(); ++i) {
    const double n = 2 * static_cast<int>(i) + 1 < full_height ? 2.0 : 1.0;
    for (int c = 0; c < 3; ++c) e[c] += n * rows[i][c];
  }
  return e;
}
// Levels this small run on one thread: below about 2^14 pixels a barrier costs more than their
// work. (It was 2^18; on the Zen 4 host, 2 threads, nothing else running, 2^14 took the pyramid of
// the 2048x1024 bench frame from 1.65-1.69 to 1.07-1.09 ms, 2^16 to 1.17-1.22: docs/benchmarks.md,
// twenty-second session. Rows are independent and the energy sums combine in row order, so the
// threshold changes no result.)
constexpr int64_t kParallelPixels = int64_t{1} << 14;

// One output row of down2 from input rows ra, rb (w pixels): pixel x averages the pairs at 2x
// and min(2x + 1, w − 1), in the order ((a0 + a1) + (b0 + b1))·¼; the interior pairs without
// the clamp, so that the loop vectorizes.
//
// Where the CPU has AVX-512, down2_row's interior 16 output pixels (48 floats) at a time
// (down2_pairs_avx512): output float i = 3x + c reads input float k(i) = 6x + c = 2i − (i mod 3)
// and k(i) + 3 of each row. For output vector v (i = 16v .. 16v + 15) the k(i) lie in a window
// of 32 floats from b_v = k(16v) = 0, 31, 62 (k(16v + 15) − b_v = 30); the pair sums
// ra[k] + ra[k + 3] and rb[k] + rb[k + 3] and their sum are formed over the whole window (two
// vectors, the second term from a load 3 floats on), one two-source permute (vpermt2ps) picks
// the 16 lanes k(i), then the ·¼: per output float the same IEEE operations in the same order,
// ((a0 + a1) + (b0 + b1))·¼, so the same bits (test GlareFastPath.SkirtEqualsTheWholeImageDefinition).
// Returns the first output pixel it left.
struct Down2Perm {
  alignas(64) int32_t idx[3][16];
  Down2Perm() {
    for (int v = 0; v < 3; ++v)
      for (int l = 0; l < 16; ++l) {
        const int i = 16 * v + l, base = 32 * v - (16 * v) % 3;
        idx[v][l] = 2 * i - i % 3 - base;
      }
  }
};
const Down2Perm kDown2Perm;
__attribute__((target("avx512f")))
int down2_pairs_avx512(const float* ra, const float* rb, int w, float* o) {
  const int pairs = w / 2;
  const __m512 quarter = _mm512_set1_ps(0.25f);
  int x = 0;
  // A block reads input floats 6x .. 6x + 96 (the last load's lane 15 lies one float past the
  // block's 32 pixels): inside the row while 6x + 97 <= 3w; its pixels are pairs while x + 16 <= pairs.
  for (; x + 16 <= pairs && 6 * x + 97 <= 3 * w; x += 16) {
    for (int v = 0; v < 3; ++v) {
      const int b = 6 * x + 32 * v - (16 * v) % 3;
      const __m512 sa0 = _mm512_add_ps(_mm512_loadu_ps(ra + b), _mm512_loadu_ps(ra + b + 3));
      const __m512 sa1 = _mm512_add_ps(_mm512_loadu_ps(ra + b + 16), _mm512_loadu_ps(ra + b + 19));
      const __m512 sb0 = _mm512_add_ps(_mm512_loadu_ps(rb + b), _mm512_loadu_ps(rb + b + 3));
      const __m512 sb1 = _mm512_add_ps(_mm512_loadu_ps(rb + b + 16), _mm512_loadu_ps(rb + b + 19));
      const __m512 q = _mm512_permutex2var_ps(_mm512_add_ps(sa0, sb0), _mm512_load_si512(kDown2Perm.idx[v]),
                                              _mm512_add_ps(sa1, sb1));
      _mm512_storeu_ps(o + 3 * x + 16 * v, _mm512_mul_ps(q, quarter));
    }
  }
  return x;
}

// With AVX2 (after the AVX-512 blocks, or alone), eight output pixels (24 floats) at a time: the
// same sums over windows of 16 floats and lanes k(i) picked from them, by two one-source permutes
// (vpermps) and a blend where AVX-512 has its two-source one. Eight lanes from i0 reach k(i0 + 7)
// − k(i0) = 14 − ((i0 + 7) mod 3) + (i0 mod 3) ≤ 13 floats on when i0 mod 3 is 0 or 1 (16 when 2,
// beyond a window), so the block's floats are written by four vectors from i0 = 0, 7, 15, 16
// (phases 0, 1, 0, 1; the overlaps are written twice with the same values). Returns the first
// output pixel it left.
constexpr int kPick8Start[4] = {0, 7, 15, 16};
// Window offsets k(i0 + l) − k(i0) of the eight lanes: phase 0 (0, 1, 2, 6, 7, 8, 12, 13), phase 1
// (0, 1, 5, 6, 7, 11, 12, 13); lanes 5-7 from the second window (offset − 8), the rest from the first.
__attribute__((target("avx2"))) inline __m256 pick8(__m256 w0, __m256 w1, int phase) {
  const __m256i idx = phase ? _mm256_setr_epi32(0, 1, 5, 6, 7, 3, 4, 5) : _mm256_setr_epi32(0, 1, 2, 6, 7, 0, 4, 5);
  return _mm256_blend_ps(_mm256_permutevar8x32_ps(w0, idx), _mm256_permutevar8x32_ps(w1, idx), 0xe0);
}
__attribute__((target("avx2"))) inline __m256 pair_sums8(const float* ra, const float* rb, int k) {
  return _mm256_add_ps(_mm256_add_ps(_mm256_loadu_ps(ra + k), _mm256_loadu_ps(ra + k + 3)),
                       _mm256_add_ps(_mm256_loadu_ps(rb + k), _mm256_loadu_ps(rb + k + 3)));
}
__attribute__((target("avx2")))
int down2_pairs_avx2(const float* ra, const float* rb, int x, int w, float* o) {
  const int pairs = w / 2;
  const __m256 quarter = _mm256_set1_ps(0.25f);
  // A block's last window (i0 = 16: k = 31, floats 31 + 8 .. 31 + 8 + 3 + 7 from 6x) reaches float
  // 6x + 49: inside the row while 6x + 50 <= 3w.
  for (; x + 8 <= pairs && 6 * x + 50 <= 3 * w; x += 8)
    for (const int i0 : kPick8Start) {
      const int k = 6 * x + 2 * i0 - i0 % 3;
      const __m256 q = pick8(pair_sums8(ra, rb, k), pair_sums8(ra, rb, k + 8), i0 % 3);
      _mm256_storeu_ps(o + 3 * x + i0, _mm256_mul_ps(q, quarter));
    }
  return x;
}

PHOTOSITE_TARGET_CLONES
void down2_row(const float* __restrict ra, const float* __restrict rb, int w, float* __restrict o) {
  const int w2 = (w + 1) / 2, pairs = w / 2;  // pixels 2x, 2x + 1 both inside for x < pairs
  int x0 = kGlareAvx512 ? down2_pairs_avx512(ra, rb, w, o) : 0;
  if (kGlareAvx2) x0 = down2_pairs_avx2(ra, rb, x0, w, o);
  for (int x = x0; x < pairs; ++x)
    for (int c = 0; c < 3; ++c) {
      const int k = 6 * x + c;
      o[3 * x + c] = ((ra[k] + ra[k + 3]) + (rb[k] + rb[k + 3])) * 0.25f;
    }
  for (int x = pairs; x < w2; ++x) {  // odd w: the last pixel averages with itself
    const int xa = 3 * (2 * x), xb = 3 * std::min(2 * x + 1, w - 1);
    for (int c = 0; c < 3; ++c) o[3 * x + c] = ((ra[xa + c] + ra[xb + c]) + (rb[xa + c] + rb[xb + c])) * 0.25f;
  }
}

// 2x2 box average, edge clamped (the last row/column of an odd size averages with itself), into
// dst, with each output row's level1_row_sum (the level-1 energy of the input) into rows
// (level1_row_sums, eight rows at a time).
void down2(const ImageF& src, ImageF& dst, std::vector<std::array<double, 3>>& rows) {
  const int w = src.width(), h = src.height();
  const int w2 = (w + 1) / 2, h2 = (h + 1) / 2;
  rows.assign(h2, {0, 0, 0});
  const int batches = (h2 + kRowSumBatch - 1) / kRowSumBatch;  // eight rows, then their sums
#pragma omp parallel for schedule(static) if (static_cast<int64_t>(w2) * h2 > kParallelPixels / 4)
  for (int b = 0; b < batches; ++b) {
    const int y0 = b * kRowSumBatch, y1 = std::min(h2, y0 + kRowSumBatch);
    const float* r[kRowSumBatch];
    for (int y = y0; y < y1; ++y) {
      float* o = dst.row(y);
      down2_row(src.row(2 * y), src.row(std::min(2 * y + 1, h - 1)), w, o);
      r[y - y0] = o;
    }
    level1_row_sums(r, y1 - y0, w2, w, rows.data() + y0);
  }
}

// down_1331's interior along a row: o[3x + k] for 1 <= x < end, from s[3(2x − 1) + k] on.
// Where the CPU has AVX-512, 16 output pixels at a time (taps1331_avx512): output float i = 3x + k
// reads s[m], s[m + 3], s[m + 6], s[m + 9] with m = 6x − 3 + k = k(i) − 3, k(i) = 2i − (i mod 3)
// as in down2_pairs_avx512, so the taps are summed over the same three windows of 32 floats
// (from 6x − 3 + 0, 31, 62) and the same permute picks the lanes: per output float the same IEEE
// operations in the same order, (⅛·a0 + ⅜·a1) + (⅜·a2 + ⅛·a3). A block's loads reach s[6x + 99]:
// inside the row (3w floats, w >= 2·end + 1) while x + 17 <= end. Returns the first x it left.
// The taps at the 16 positions a .. a + 15.
__attribute__((target("avx512f"))) inline __m512 taps1331_window(const float* a, __m512 c1, __m512 c3) {
  return _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(c1, _mm512_loadu_ps(a)), _mm512_mul_ps(c3, _mm512_loadu_ps(a + 3))),
                       _mm512_add_ps(_mm512_mul_ps(c3, _mm512_loadu_ps(a + 6)), _mm512_mul_ps(c1, _mm512_loadu_ps(a + 9))));
}
__attribute__((target("avx512f")))
int taps1331_avx512(const float* s, int end, float* o) {
  const __m512 c1 = _mm512_set1_ps(0.125f), c3 = _mm512_set1_ps(0.375f);
  int x = 1;
  for (; x + 17 <= end; x += 16)
    for (int v = 0; v < 3; ++v) {
      const float* a = s + 6 * x - 3 + 32 * v - (16 * v) % 3;
      _mm512_storeu_ps(o + 3 * x + 16 * v,
                       _mm512_permutex2var_ps(taps1331_window(a, c1, c3), _mm512_load_si512(kDown2Perm.idx[v]),
                                              taps1331_window(a + 16, c1, c3)));
    }
  return x;
}
// The same with AVX2, eight output pixels at a time (down2_pairs_avx2's windows and picks; the last
// window's loads reach s[6x − 3 + 31 + 8 + 9 + 7] = s[6x + 52]: inside the row while x + 9 <= end).
__attribute__((target("avx2"))) inline __m256 taps1331_window8(const float* a, __m256 c1, __m256 c3) {
  return _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(c1, _mm256_loadu_ps(a)), _mm256_mul_ps(c3, _mm256_loadu_ps(a + 3))),
                       _mm256_add_ps(_mm256_mul_ps(c3, _mm256_loadu_ps(a + 6)), _mm256_mul_ps(c1, _mm256_loadu_ps(a + 9))));
}
__attribute__((target("avx2")))
int taps1331_avx2(const float* s, int x, int end, float* o) {
  const __m256 c1 = _mm256_set1_ps(0.125f), c3 = _mm256_set1_ps(0.375f);
  for (; x + 9 <= end; x += 8)
    for (const int i0 : kPick8Start) {
      const float* a = s + 6 * x - 3 + 2 * i0 - i0 % 3;
      _mm256_storeu_ps(o + 3 * x + i0, pick8(taps1331_window8(a, c1, c3), taps1331_window8(a + 8, c1, c3), i0 % 3));
    }
  return x;
}
PHOTOSITE_TARGET_CLONES
void taps1331_row(const float* __restrict s, int end, float* __restrict o) {
  int x0 = kGlareAvx512 ? taps1331_avx512(s, end, o) : 1;
  if (kGlareAvx2) x0 = taps1331_avx2(s, x0, end, o);
  for (int x = x0; x < end; ++x) {
    const float* a = s + 3 * (2 * x - 1);
    for (int k = 0; k < 3; ++k)
      o[3 * x + k] = (0.125f * a[k] + 0.375f * a[3 + k]) + (0.375f * a[6 + k] + 0.125f * a[9 + k]);
  }
}
// down_1331 along columns: one output row from its four input rows.
PHOTOSITE_TARGET_CLONES
void taps1331_cols(const float* __restrict a, const float* __restrict b, const float* __restrict c,
                   const float* __restrict d, size_t n, float* __restrict o) {
  for (size_t j = 0; j < n; ++j) o[j] = (0.125f * a[j] + 0.375f * b[j]) + (0.375f * c[j] + 0.125f * d[j]);
}
// The (1,3,3,1)/8 taps along one row of w pixels (mirror borders): o holds (w + 1)/2 pixels.
void taps1331_along_row(const float* s, int w, float* o) {
  const int w2 = (w + 1) / 2;
  auto at = [&](int x) {
    const float* a = s + 3 * glare_mirror(2 * x - 1, w);
    const float* b = s + 3 * glare_mirror(2 * x, w);
    const float* c = s + 3 * glare_mirror(2 * x + 1, w);
    const float* d = s + 3 * glare_mirror(2 * x + 2, w);
    for (int k = 0; k < 3; ++k)
      o[3 * x + k] = (0.125f * a[k] + 0.375f * b[k]) + (0.375f * c[k] + 0.125f * d[k]);
  };
  const int inner_end = std::max(1, (w - 1) / 2);  // x < inner_end: 2x + 2 <= w − 1, no mirror
  at(0);
  taps1331_row(s, inner_end, o);
  for (int x = std::max(1, inner_end); x < w2; ++x) at(x);
}

// The rows [ya, yb) of n that thread t of nt walks (contiguous ranges in order: any split gives
// the same rows, each computed by one thread).
inline std::pair<int, int> thread_rows(int n) {
  const int nt = omp_get_num_threads(), t = omp_get_thread_num();
  return {static_cast<int>(static_cast<int64_t>(n) * t / nt), static_cast<int>(static_cast<int64_t>(n) * (t + 1) / nt)};
}

// Down one octave with the taps (1, 3, 3, 1)/8 per axis, the transpose of the bilinear
// upsampling (mirror borders): unlike a 2x2 box it keeps a point source's centroid where it
// was, so coarse levels spread a lamp's glare around the lamp, not around a coarse pixel
// centre up to 2^(l-1) px away. Rows first, then columns; each sum in this order. The source is
// w x h pixels, its row j given by src_row(j, k, ka, kb, scratch) (k: the unmirrored index asked
// for; [ka, kb) = [2·ya, 2·yb): this thread's share of the source rows, asked for in order). Each thread walks
// a contiguous range of output rows and keeps the row pass of the four source rows it needs
// (2y − 1 .. 2y + 2, mirrored) in a ring, making two new ones per output row: the row pass is
// never written as an image, and every output sample is the same sums in the same order.
template <class SrcRow>
void down_1331(int w, int h, const SrcRow& src_row, size_t scratch_floats, bool parallel, ImageF& dst) {
  const int w2 = (w + 1) / 2, h2 = (h + 1) / 2;
  const size_t n2 = 3 * static_cast<size_t>(w2);
#pragma omp parallel if (parallel)
  {
    const auto [ya, yb] = thread_rows(h2);
    std::vector<float> ring(4 * n2), scratch(scratch_floats);
    auto slot = [&](int k) { return ring.data() + static_cast<size_t>((k + 4) & 3) * n2; };  // k >= −1
    auto make = [&](int k) {
      taps1331_along_row(src_row(glare_mirror(k, h), k, 2 * ya, 2 * yb, scratch.data()), w, slot(k));
    };
    for (int y = ya; y < yb; ++y) {
      if (y == ya) {
        make(2 * y - 1);
        make(2 * y);
      }
      make(2 * y + 1);
      make(2 * y + 2);
      taps1331_cols(slot(2 * y - 1), slot(2 * y), slot(2 * y + 1), slot(2 * y + 2), n2, dst.row(y));
    }
  }
}
// down_1331 of an image.
void down_1331(const ImageF& src, ImageF& dst) {
  const int w = src.width(), h = src.height();
  down_1331(w, h, [&](int j, int, int, int, float*) { return src.row(j); }, 0,
            static_cast<int64_t>((w + 1) / 2) * h > kParallelPixels, dst);
}
// Level 2 straight from the irradiance: down_1331 of down2(in), level 1's rows made by the 2x2
// box as the (1,3,3,1) pass asks for them (so level 1 is never written as an image), with
// level 1's row sums into rows (each by the thread that owns the row: the same sums as down2's).
// A thread's own rows k in [ka, kb) ∩ [0, h1) (asked for once each, in order) go to slot k mod 8
// of its scratch and are summed eight at a time (level1_row_sums) when slot 7 or the last of
// them is made; rows outside that range (the halo, the mirrored rows) use a ninth slot.
void down2_then_1331(const ImageF& in, ImageF& dst, std::vector<std::array<double, 3>>& rows) {
  const int w = in.width(), h = in.height();
  const int w1 = (w + 1) / 2, h1 = (h + 1) / 2;
  const size_t n1 = 3 * static_cast<size_t>(w1);
  rows.assign(h1, {0, 0, 0});
  down_1331(
      w1, h1,
      [&](int j, int k, int ka, int kb, float* buf) {
        const bool own = k == j && k >= ka && k < kb;
        float* o = buf + n1 * static_cast<size_t>(own ? k % kRowSumBatch : kRowSumBatch);
        down2_row(in.row(2 * j), in.row(std::min(2 * j + 1, h - 1)), w, o);
        const int last = std::min(kb, h1) - 1;
        if (own && (k % kRowSumBatch == kRowSumBatch - 1 || k == last)) {
          const int k0 = std::max(ka, k - k % kRowSumBatch);
          const float* r[kRowSumBatch];
          for (int i = k0; i <= k; ++i) r[i - k0] = buf + n1 * static_cast<size_t>(i % kRowSumBatch);
          level1_row_sums(r, k - k0 + 1, w1, w, rows.data() + k0);
        }
        return static_cast<const float*>(o);
      },
      (kRowSumBatch + 1) * n1, static_cast<int64_t>(w1) * h1 > kParallelPixels / 4, dst);
}

// The Gaussian blur along one row of w pixels (taps centre first), mirror borders: the row is
// first copied into a padded row (the mirror resolved once; pad holds 3·(w + 2R) floats), then
// every output sums its taps from −R to R.
void blur_row(const float* s, int w, const std::array<float, kGlareBlurRadius + 1>& g, float* pad, float* o) {
  constexpr int R = kGlareBlurRadius;
  // The interior x in [0, w) is its own mirror: copied whole; glare_mirror (a division) only on
  // the 2R border pixels.
  std::copy_n(s, 3 * static_cast<size_t>(w), pad + 3 * R);
  for (int x = -R; x < 0; ++x)
    for (int c = 0; c < 3; ++c) pad[3 * (x + R) + c] = s[3 * glare_mirror(x, w) + c];
  for (int x = w; x < w + R; ++x)
    for (int c = 0; c < 3; ++c) pad[3 * (x + R) + c] = s[3 * glare_mirror(x, w) + c];
  const float* p[2 * R + 1];
  for (int k = -R; k <= R; ++k) p[k + R] = pad + 3 * (R + k);
  blur_taps(p, blur_weights(g).data(), 3 * static_cast<size_t>(w), false, 0.f, nullptr, o);
}

// One level of the way up, into dst (width x height): acc_l = w·blur(level) + up(acc_{l+1})
// (the second term only when coarse is not null; level null: acc_l = up(acc_{l+1}), the levels
// finer than lo). The blur is separable, rows first (blur_row), mirror borders. Per sample: the
// upsampled value u (vertical interpolation first, then horizontal), the column sum
// a = Σ_{k=−R..R} g_|k|·rowblur(y + k) in that order, then w·a + u. Each thread walks a
// contiguous range of rows and keeps the row blur of the 2R + 1 rows it needs in a ring (one new
// row per output row), so the row-blurred level is never written as an image.
void accumulate(const ImageF* level, const ImageF* coarse, float w, int width, int height,
                const std::array<float, kGlareBlurRadius + 1>& g, ImageF& dst,
                std::vector<std::array<double, 3>>* rows, int full_width) {
  constexpr int R = kGlareBlurRadius, kRing = 2 * R + 1;
  const bool blur = level != nullptr, up = coarse != nullptr;
  const int cw = up ? coarse->width() : 0, ch = up ? coarse->height() : 0;
  const size_t n = 3 * static_cast<size_t>(width);
  if (rows) rows->assign(height, {0, 0, 0});
  const auto gk = blur_weights(g);
#pragma omp parallel if (static_cast<int64_t>(width) * height > kParallelPixels)
  {
    const auto [ya, yb] = thread_rows(height);
    // t, then e, o of upsample_row, staggered within a page as in glare_row_layout (at cw = 512,
    // packed, t and o began 3 pages apart); u; the ring of row blurs and blur_row's padded row
    const size_t ce = glare_page_stagger(3 * static_cast<size_t>(cw), 1),
                 co = glare_page_stagger(ce + 3 * static_cast<size_t>(cw), 2);
    std::vector<float> tmp(up ? co + 3 * static_cast<size_t>(cw) : 0), u(up && blur ? n : 0),
        ring(blur ? kRing * n : 0), pad(blur ? 3 * static_cast<size_t>(width + 2 * R) : 0);
    auto slot = [&](int k) { return ring.data() + static_cast<size_t>((k % kRing + kRing) % kRing) * n; };
    auto make = [&](int k) { blur_row(level->row(glare_mirror(k, height)), width, g, pad.data(), slot(k)); };
    for (int y = ya; y < yb; ++y) {
      float* o = dst.row(y);
      if (up) {
        const UpTap ty = glare_up_tap(y, ch);
        lerp_row(ty.w0, coarse->row(ty.i0), ty.w1, coarse->row(ty.i1), 3 * static_cast<size_t>(cw), tmp.data());
        upsample_row(tmp.data(), cw, width, blur ? u.data() : o, tmp.data() + ce, tmp.data() + co);
      }
      if (blur) {
        if (y == ya)
          for (int k = y - R; k < y + R; ++k) make(k);
        make(y + R);
        const float* p[kRing];
        for (int k = -R; k <= R; ++k) p[k + R] = slot(y + k);
        blur_taps(p, gk.data(), n, true, w, up ? u.data() : nullptr, o);
      }
      // The row sums eight rows at a time (level1_row_sums), each batch while its rows are in cache.
      if (rows && ((y - ya) % kRowSumBatch == kRowSumBatch - 1 || y == yb - 1)) {
        const int y0 = y - (y - ya) % kRowSumBatch;
        const float* r[kRowSumBatch];
        for (int k = y0; k <= y; ++k) r[k - y0] = dst.row(k);
        level1_row_sums(r, y - y0 + 1, width, full_width, rows->data() + y0);
      }
    }
  }
}

// The pyramid's images, kept per thread between calls: a caller that runs frame after frame
// (batch, bench night) reuses their pages instead of faulting in fresh ones each frame (the
// level and accumulator images of a 2048x1024 frame, about 4 MB, and acc_1, 6 MB). acc_1 is
// shared with the skirt returned; it is written again only when no skirt holds it any more.
struct GlareWorkspace {
  std::vector<ImageF> level, acc;  // [l], l = 1 .. hi (level 1 only when it is blurred; acc 2 .. hi)
  std::shared_ptr<ImageF> acc1;
};
thread_local GlareWorkspace t_workspace;
std::atomic<uint64_t> g_full_resolution_level1{0};  // detail::glare_full_resolution_level1_count

// img as a w x h x 3 image, its buffer kept where it has that shape already.
ImageF& shaped(ImageF& img, int w, int h, const std::string& unit) {
  if (!img.same_shape(w, h) || img.channels() != 3) img = ImageF(w, h, 3, uninitialized, unit);
  img.set_unit(unit);
  return img;
}
}  // namespace

double px_per_degree(double focal_length_mm, double pixel_pitch_um) {
  return focal_length_mm * 1e-3 / (pixel_pitch_um * 1e-6) * units::pi / 180.0;
}

std::array<float, kGlareBlurRadius + 1> glare_blur_taps() {
  // Gaussian σ = 1 level pixel sampled at the integers, cut at 3σ, normalised in double.
  double g[kGlareBlurRadius + 1], sum = 0;
  for (int k = 0; k <= kGlareBlurRadius; ++k) {
    g[k] = std::exp(-0.5 * k * k);
    sum += k == 0 ? g[k] : 2 * g[k];
  }
  std::array<float, kGlareBlurRadius + 1> out{};
  for (int k = 0; k <= kGlareBlurRadius; ++k) out[k] = static_cast<float>(g[k] / sum);
  return out;
}

GlarePlan plan_glare(const LensGlare& glare, double px_per_deg) {
  GlarePlan p;
  if (!glare.enabled || !(glare.veiling_glare_index > 0)) return p;
  if (!(px_per_deg > 0) || !std::isfinite(px_per_deg))
    fail("glare: pixels per degree must be positive and finite");
  const auto g = glare_blur_taps();
  double var_b = 0;  // the discrete blur's variance (level px²)
  for (int k = 1; k <= kGlareBlurRadius; ++k) var_b += 2.0 * k * k * g[k];
  // A point source's spread on level l (px² per axis, phase-averaged): the 2x2 box to level 1
  // adds 1/4, each (1,3,3,1)/8 step m = 2..l adds 3/4·4^(m−1), each bilinear step m = 1..l back
  // up adds 3/16·4^m, the blur σ_b²·4^l: in all 4^l·(σ_b² + 1/2) − 1.
  auto sigma = [&](int l) {
    const double f = std::ldexp(1.0, 2 * l);
    return std::sqrt(f * (var_b + 0.5) - 1.0);
  };
  auto nearest = [&](double target_px) {
    int best = 1;
    for (int l = 2; l <= kMaxLevel; ++l)
      if (std::fabs(std::log(sigma(l) / target_px)) < std::fabs(std::log(sigma(best) / target_px))) best = l;
    return best;
  };
  p.active = true;
  p.eta = glare.veiling_glare_index;
  p.keep = static_cast<float>(1.0 - glare.veiling_glare_index);
  p.lo = nearest(glare.core_deg * px_per_deg);
  p.hi = std::max(p.lo, nearest(0.5 * glare.reach_deg * px_per_deg));
  // A sum of unit Gaussians at σ_l with weights ∝ σ_l^(2−p) has density ∝ Σ σ_l^(−p)·e^(−θ²/2σ_l²)
  // ≈ θ^(−p) between σ_lo and σ_hi.
  double total = 0;
  for (int l = p.lo; l <= p.hi; ++l) {
    p.sigma_px.push_back(sigma(l));
    total += std::pow(sigma(l), 2.0 - glare.skirt_exponent);
  }
  for (int l = p.lo; l <= p.hi; ++l)
    p.weight.push_back(static_cast<float>(std::pow(sigma(l), 2.0 - glare.skirt_exponent) / total));
  return p;
}

void detail::glare_level1_row_sums(const float* const* r, int nr, int w, int full_width, std::array<double, 3>* out) {
  if (nr < 0 || nr > kRowSumBatch) fail("glare_level1_row_sums: at most 8 rows");
  level1_row_sums(r, nr, w, full_width, out);
}

uint64_t detail::glare_full_resolution_level1_count() {
  return g_full_resolution_level1.load(std::memory_order_relaxed);
}

std::array<double, 3> glare_level1_energy(const ImageF& v, int full_width, int full_height) {
  std::vector<std::array<double, 3>> rows(v.height());
  for (int i = 0; i < v.height(); ++i) rows[i] = level1_row_sum(v.row(i), v.width(), full_width);
  return combine_rows(rows, full_height);
}

GlareLevel1::GlareLevel1(int w, int h)
    : full_width(w), full_height(h),
      image(glare_level_size(w, 1), glare_level_size(h, 1), 3, uninitialized, unit::radiance),
      row_sums(static_cast<size_t>(glare_level_size(h, 1)), {0, 0, 0}) {}

static_assert(kGlareLevel1SumRows == kRowSumBatch);
void glare_level1_row(const ImageF& in, int j, GlareLevel1& l1) {
  // down2's row j: the same level row as glare_skirt's.
  const int h = in.height();
  down2_row(in.row(2 * j), in.row(std::min(2 * j + 1, h - 1)), in.width(), l1.image.row(j));
}
void glare_level1_sums(GlareLevel1& l1, int j0, int j1) {
  // level1_row_sums eight rows at a time (each row's sums its own chain, whatever the batch): the
  // same sums as glare_skirt's.
  for (int k0 = j0; k0 < j1; k0 += kRowSumBatch) {
    const int k1 = std::min(j1, k0 + kRowSumBatch);
    const float* r[kRowSumBatch];
    for (int k = k0; k < k1; ++k) r[k - k0] = l1.image.row(k);
    level1_row_sums(r, k1 - k0, l1.image.width(), l1.full_width, l1.row_sums.data() + k0);
  }
}

GlareSkirt glare_skirt(const ImageF& in, const GlarePlan& plan) { return glare_skirt(in, plan, nullptr); }

GlareSkirt glare_skirt(const ImageF& in, const GlarePlan& plan, const GlareLevel1* level1) {
  GlareSkirt s;
  s.width = in.width();
  s.height = in.height();
  if (!plan.active) return s;
  if (in.channels() != 3) fail("glare: the irradiance must have 3 channels");
  if (in.width() < 1 || in.height() < 1) return s;
  const auto g = glare_blur_taps();
  GlareWorkspace& ws = t_workspace;
  ws.level.resize(plan.hi + 1);
  ws.acc.resize(plan.hi + 1);
  if (!ws.acc1 || ws.acc1.use_count() > 1) ws.acc1 = std::make_shared<ImageF>();
  std::atomic_thread_fence(std::memory_order_acquire);  // after the last skirt's release of acc1
  const std::string& unit = in.unit();
  auto level_image = [&](int l) -> ImageF& {
    return shaped(ws.level[l], glare_level_size(s.width, l), glare_level_size(s.height, l), unit);
  };
  // The level-1 energies' row sums come out of the passes that make level 1 and acc_1 (the
  // same sums as glare_level1_energy, without another pass over memory).
  std::vector<std::array<double, 3>> rows_in, rows_skirt;
  // level[l]: the level images (level 1 the caller's where it made it).
  const ImageF* level[kMaxLevel + 1] = {};
  int l = 2;
  if (level1) {
    if (level1->full_width != s.width || level1->full_height != s.height ||
        !level1->image.same_shape(glare_level_size(s.width, 1), glare_level_size(s.height, 1)) ||
        level1->image.channels() != 3 || static_cast<int>(level1->row_sums.size()) != level1->image.height())
      fail("glare: the level 1 handed in is not that of a " + std::to_string(s.width) + "x" +
           std::to_string(s.height) + " image");
    level[1] = &level1->image;
    rows_in = level1->row_sums;
  } else if (plan.lo == 1) {
    g_full_resolution_level1.fetch_add(1, std::memory_order_relaxed);
    down2(in, level_image(1), rows_in);  // level 1 is blurred: kept as an image
    level[1] = &ws.level[1];
  } else {
    g_full_resolution_level1.fetch_add(1, std::memory_order_relaxed);
    down2_then_1331(in, level_image(2), rows_in);  // lo >= 2 <= hi: level 1 is only a step
    level[2] = &ws.level[2];
    l = 3;
  }
  // (down_1331 of level 1 is down2_then_1331's level 2: the same rows into the same taps.)
  for (; l <= plan.hi; ++l) {
    down_1331(*level[l - 1], level_image(l));
    level[l] = &ws.level[l];
  }
  const ImageF* coarse = nullptr;
  for (l = plan.hi; l >= 1; --l) {
    const int w = glare_level_size(s.width, l), h = glare_level_size(s.height, l);
    ImageF& acc = shaped(l == 1 ? *ws.acc1 : ws.acc[l], w, h, unit::radiance);
    const bool blurred = l >= plan.lo;
    accumulate(blurred ? level[l] : nullptr, coarse, blurred ? plan.weight[l - plan.lo] : 0.f, w, h, g, acc,
               l == 1 ? &rows_skirt : nullptr, s.width);
    coarse = &acc;
  }
  const auto e_in = combine_rows(rows_in, s.height);
  const auto e_skirt = combine_rows(rows_skirt, s.height);
  for (int c = 0; c < 3; ++c)
    s.scale[c] = e_skirt[c] > 0 ? static_cast<float>(plan.eta * e_in[c] / e_skirt[c]) : 0.f;
  s.keep = plan.keep;
  s.acc1 = ws.acc1;
  return s;
}

detail::GlareVerticalTaps detail::glare_skirt_vertical_taps(const GlareSkirt& s, int y) {
  const ImageF& a = *s.acc1;
  const UpTap ty = glare_up_tap(y, a.height());
  return {a.row(ty.i0), a.row(ty.i1), ty.w0, ty.w1};
}

void detail::glare_vertical_lerp(const GlareVerticalTaps& v, size_t k0, size_t k1, float* t) {
  if (k0 < k1) lerp_row(v.w0, v.a + k0, v.w1, v.b + k0, k1 - k0, t + k0);
}

const float* detail::glare_skirt_vertical_row(const GlareSkirt& s, int y, float* tmp) {
  float* t = tmp + glare_row_layout(s).t;  // 3·aw: the vertical interpolation
  glare_vertical_lerp(glare_skirt_vertical_taps(s, y), 0, 3 * static_cast<size_t>(s.acc1->width()), t);
  return t;
}

const float* glare_skirt_row(const GlareSkirt& s, int y, float* tmp) {
  const GlareRowLayout l = glare_row_layout(s);
  const float* t = detail::glare_skirt_vertical_row(s, y, tmp);
  float* u = tmp + l.u;  // 3·width: then the horizontal interpolation
  upsample_row(t, s.acc1->width(), s.width, u, tmp + l.e, tmp + l.o);  // e, o: upsample_row's scratch
  return u;
}

void glare_row(const GlareSkirt& s, int y, const float* in, float* out, float* tmp) {
  const int cw = s.acc1->width();
  if (!kGlareAvx512 || cw < 3) {
    const float* u = glare_skirt_row(s, y, tmp);
    mix_row(s.keep, s.scale.data(), in, u, 3 * static_cast<size_t>(s.width), out);
    return;
  }
  // Where the CPU has AVX-512: the interior pairs upsampled and mixed in registers
  // (upsample_mix_pairs_avx512), the rest (pixels 0, 1 and from the first pair left on, by
  // upsample_row's per-pixel step glare_up_pixel) by mix_row: the same operations per sample.
  const float* t = detail::glare_skirt_vertical_row(s, y, tmp);
  const int j1 = upsample_mix_pairs_avx512(t, cw, s.keep, s.scale.data(), in, out);
  float* u = tmp + glare_row_layout(s).u;
  auto rest = [&](int xa, int xb) {
    for (int x = xa; x < xb; ++x) detail::glare_up_pixel(t, cw, x, u + 3 * (x - xa));
    mix_row(s.keep, s.scale.data(), in + 3 * xa, u, 3 * static_cast<size_t>(xb - xa), out + 3 * xa);
  };
  rest(0, 2);
  rest(2 * j1, s.width);
}

ImageF apply_glare(const ImageF& in, const LensGlare& glare, double px_per_deg) {
  const GlareSkirt s = glare_skirt(in, plan_glare(glare, px_per_deg));
  if (!s.active()) return in;
  ImageF out(in.width(), in.height(), 3, uninitialized, in.unit());
#pragma omp parallel
  {
    std::vector<float> tmp(glare_row_scratch(s));
#pragma omp for schedule(static)
    for (int y = 0; y < in.height(); ++y) glare_row(s, y, in.row(y), out.row(y), tmp.data());
  }
  return out;
}

}  // namespace photosite
