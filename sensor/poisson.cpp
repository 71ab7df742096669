#include "photosite/sensor/poisson.h"

#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <utility>
#include <immintrin.h>

#include "core/isa_detail.h"
#include "photosite/error.h"
#include "sensor/poisson_detail.h"

namespace photosite {
namespace shader {

const float kInverseInteger[64] = {
    0,         1.f / 1,  1.f / 2,  1.f / 3,  1.f / 4,  1.f / 5,  1.f / 6,  1.f / 7,  1.f / 8,
    1.f / 9,   1.f / 10, 1.f / 11, 1.f / 12, 1.f / 13, 1.f / 14, 1.f / 15, 1.f / 16, 1.f / 17,
    1.f / 18,  1.f / 19, 1.f / 20, 1.f / 21, 1.f / 22, 1.f / 23, 1.f / 24, 1.f / 25, 1.f / 26,
    1.f / 27,  1.f / 28, 1.f / 29, 1.f / 30, 1.f / 31, 1.f / 32, 1.f / 33, 1.f / 34, 1.f / 35,
    1.f / 36,  1.f / 37, 1.f / 38, 1.f / 39, 1.f / 40, 1.f / 41, 1.f / 42, 1.f / 43, 1.f / 44,
    1.f / 45,  1.f / 46, 1.f / 47, 1.f / 48, 1.f / 49, 1.f / 50, 1.f / 51, 1.f / 52, 1.f / 53,
    1.f / 54,  1.f / 55, 1.f / 56, 1.f / 57, 1.f / 58, 1.f / 59, 1.f / 60, 1.f / 61, 1.f / 62,
    1.f / 63};

}  // namespace shader

namespace {
// Pixels per block of poisson_block (a 2048-pixel row in one block). Larger blocks give the
// compacted PTRS passes (full test, retries) more lanes per call: at 256, a night frame's block
// retried ~35 lanes per call, padded to whole vectors, with the per-call cost on each. On the
// night bench frame's means (poisson_block over 2048x1024, 1 thread, best of 30 CPU times, Intel
// Xeon): 21.3-22.3 ms at 256 before pack_lanes, 20.8-21.9 at 256 with it, 19.0-19.5 at 1024
// (2048: the same there). On the Zen 3 host (AVX2, 2026-12-01; `bench night --threads 1
// --cpu-clock`, `cpu: sensor (expose)` of ~34 ms, rounds alternating the builds, the rest of the
// code the same): 512 took 0.8-0.9 ms more than 1024 in each of 3 rounds, 2048 0.6-1.0 ms less
// in each of 3 (docs/benchmarks.md, "Thirtieth session: the sensor on the AVX2-only host").
// The stack arrays of a block take ~360 KB at 2048 over the deepest calls (poisson_block 72,
// ptrs_high_lanes 48, ptrs_block 152, ptrs_attempts 16 and ptrs_first_attempt 72 KB, their AVX2
// clones' frames), against a default glibc thread stack of 8 MB and a macOS secondary thread's
// 512 KB. No draw depends on the block size.
constexpr int kBlock = 2048;

// The scalar Philox (kernels/common/philox_round.glsl) for one pixel, its four words stored at
// index j of w0..w3.
inline void philox_one(uint64_t key, uint32_t frame, uint64_t pixel, uint32_t stream, int j, uint32_t* w0,
                       uint32_t* w1, uint32_t* w2, uint32_t* w3) {
  const auto w = detail::random_words_inline(key, frame, pixel, stream);
  w0[j] = w[0];
  w1[j] = w[1];
  w2[j] = w[2];
  w3[j] = w[3];
}
// Philox4x32-10 over a block of consecutive pixels, bit-identical to rng.h's scalar Philox.
void philox_words_scalar(uint64_t key, uint32_t frame, uint64_t first_pixel, uint32_t stream, int n,
                         uint32_t* w0, uint32_t* w1, uint32_t* w2, uint32_t* w3) {
  for (int j = 0; j < n; ++j) philox_one(key, frame, first_pixel + j, stream, j, w0, w1, w2, w3);
}

// The same on vectors of N 32-bit lanes, written once for AVX2 (N = 8) and AVX-512 (N = 16) by
// the macro PHILOX_SIMD below: a documented SIMD twin of philox4x32_round and philox4x32_10
// (kernels/common/philox_round.glsl). mul_epu32 forms the 32x32->64 products of the even lanes;
// the odd lanes are shifted down and multiplied the same way, and the high and low halves are
// put back in place (AVX2: a shift and a blend each; AVX-512: one masked dword swap each, and one
// ternary-logic instruction, 0x96 = a ^ b ^ c, per three-way xor). Integer operations only, so every width gives the scalar Philox's words:
// Philox.BlockWordsEqualScalarOnEveryPath and Philox.PoissonDrawsEqualOnEveryPathAndThreadCount
// (tests/sensor_fast_paths_test.cpp), Poisson.BlockKernelMatchesScalarPhiloxWords,
// PoissonAccuracy.PtrsBlockEqualsScalarReference and Philox.KnownAnswers. Each width defines
//  * philox_lanes_N<Rounds, B>(c0, c1, ...): B vectors of N pixels whose indices' low and high
//    halves are c0[b], c1[b], their rounds interleaved (U, the width's B for whole runs: 4 on
//    both; see kPhiloxAvx2Blocks and kPhiloxAvx512Blocks);
//  * philox_words_N: consecutive pixels first_pixel.., U * N then N at a time while the high
//    half stays the same, the rest by TAIL (the next narrower path);
//  * philox_list_N: the first n & ~(N − 1) of a list of pixels (PTRS retries), U * N then N at
//    a time, pixel_lo/hi the 64-bit indices' halves.
// Rounds is kPhiloxRounds (10) everywhere but in the generator benchmark (philox_words_rounds),
// which times 7 rounds beside 10. OP(x) is the width's intrinsic _mm256_x or _mm512_x.
// Two things are done once per call rather than once per N pixels: the round keys (ka, kb
// advanced by the Weyl constants), kept in a table ks[2r], ks[2r + 1] whose entries the
// rounds broadcast from memory (no shuffle-port work), and the first round's product of the
// counter's word 2 (the frame, the same for every pixel): its halves first_hi, first_lo.
// MULHILO(c, m, hi, lo) forms the high and low 32-bit halves of the products of the 32-bit
// lanes c by m (see each width below).
#define PHILOX_SIMD(ISA, V, N, U, OP, MULHILO, XOR3, LOAD, STORE, LANES, TAIL)                                     \
  template <int Rounds>                                                                                          \
  struct PhiloxKeys##N {                                                                                         \
    uint32_t ks[2 * Rounds];                                                                                     \
    uint32_t first_hi[N], first_lo[N];                                                                           \
    __attribute__((target(ISA))) PhiloxKeys##N(uint64_t key, uint32_t frame) {                                    \
      uint32_t ka = static_cast<uint32_t>(key), kb = static_cast<uint32_t>(key >> 32);                           \
      for (int r = 0; r < Rounds; ++r) {                                                                         \
        ks[2 * r] = ka;                                                                                          \
        ks[2 * r + 1] = kb;                                                                                      \
        ka += shader::kPhiloxW0;                                                                                 \
        kb += shader::kPhiloxW1;                                                                                 \
      }                                                                                                          \
      V hi, lo;                                                                                                  \
      MULHILO(OP(set1_epi32)(static_cast<int>(frame)), OP(set1_epi32)(static_cast<int>(shader::kPhiloxM1)), hi, lo); \
      STORE(first_hi, hi);                                                                                       \
      STORE(first_lo, lo);                                                                                       \
    }                                                                                                            \
  };                                                                                                             \
  /* B independent vectors of N pixels each (vector b's pixels stored at b * N), the rounds of the */            \
  /* B vectors interleaved so that their dependency chains overlap. */                                           \
  template <int Rounds = shader::kPhiloxRounds, int B = 1>                                                       \
  __attribute__((target(ISA), always_inline)) inline void philox_lanes_##N(                                       \
      const V (&c0_in)[B], const V (&c1_in)[B], const PhiloxKeys##N<Rounds>& k, uint32_t stream, uint32_t* w0,    \
      uint32_t* w1, uint32_t* w2, uint32_t* w3) {                                                                \
    const V m0 = OP(set1_epi32)(static_cast<int>(shader::kPhiloxM0));                                            \
    const V m1 = OP(set1_epi32)(static_cast<int>(shader::kPhiloxM1));                                            \
    V c0[B], c1[B], c2[B], c3[B];                                                                                \
    for (int b = 0; b < B; ++b) {                                                                                \
      V hi0, lo0;                                                                                                \
      MULHILO(c0_in[b], m0, hi0, lo0);                                                                           \
      c0[b] = XOR3(LOAD(k.first_hi), c1_in[b], OP(set1_epi32)(static_cast<int>(k.ks[0])));                      \
      c1[b] = LOAD(k.first_lo);                                                                                  \
      c2[b] = XOR3(hi0, OP(set1_epi32)(static_cast<int>(stream)), OP(set1_epi32)(static_cast<int>(k.ks[1])));   \
      c3[b] = lo0;                                                                                               \
    }                                                                                                            \
    for (int r = 1; r < Rounds; ++r)                                                                             \
      for (int b = 0; b < B; ++b) {                                                                              \
        V hi0, lo0, hi1, lo1;                                                                                    \
        MULHILO(c0[b], m0, hi0, lo0);                                                                            \
        MULHILO(c2[b], m1, hi1, lo1);                                                                            \
        c0[b] = XOR3(hi1, c1[b], OP(set1_epi32)(static_cast<int>(k.ks[2 * r])));                                \
        c1[b] = lo1;                                                                                             \
        c2[b] = XOR3(hi0, c3[b], OP(set1_epi32)(static_cast<int>(k.ks[2 * r + 1])));                            \
        c3[b] = lo0;                                                                                             \
      }                                                                                                          \
    for (int b = 0; b < B; ++b) {                                                                                \
      STORE(w0 + b * N, c0[b]);                                                                                  \
      STORE(w1 + b * N, c1[b]);                                                                                  \
      STORE(w2 + b * N, c2[b]);                                                                                  \
      STORE(w3 + b * N, c3[b]);                                                                                  \
    }                                                                                                            \
  }                                                                                                              \
  /* Pixels p.. (B * N of them, the high half of their indices the same). */                                     \
  template <int Rounds, int B>                                                                                   \
  __attribute__((target(ISA), always_inline)) inline void philox_run_##N(                                         \
      uint64_t p, const PhiloxKeys##N<Rounds>& k, uint32_t stream, uint32_t* w0, uint32_t* w1, uint32_t* w2,      \
      uint32_t* w3) {                                                                                            \
    V c0[B], c1[B];                                                                                              \
    for (int b = 0; b < B; ++b) {                                                                                \
      c0[b] = OP(add_epi32)(OP(set1_epi32)(static_cast<int>(static_cast<uint32_t>(p) + b * N)), LANES);          \
      c1[b] = OP(set1_epi32)(static_cast<int>(static_cast<uint32_t>(p >> 32)));                                  \
    }                                                                                                            \
    philox_lanes_##N<Rounds, B>(c0, c1, k, stream, w0, w1, w2, w3);                                              \
  }                                                                                                              \
  template <int Rounds = shader::kPhiloxRounds>                                                                  \
  __attribute__((target(ISA))) void philox_words_##N(uint64_t key, uint32_t frame, uint64_t first_pixel,          \
                                                     uint32_t stream, int n, uint32_t* w0, uint32_t* w1,          \
                                                     uint32_t* w2, uint32_t* w3) {                                \
    const PhiloxKeys##N<Rounds> k(key, frame);                                                                   \
    const auto same_high = [&](int j, int count) {                                                               \
      return ((first_pixel + j) >> 32) == ((first_pixel + j + count - 1) >> 32);                                 \
    };                                                                                                           \
    int j = 0;                                                                                                   \
    if constexpr (U > 1)                                                                                         \
      for (; j + U * N <= n && same_high(j, U * N); j += U * N)                                                  \
        philox_run_##N<Rounds, U>(first_pixel + j, k, stream, w0 + j, w1 + j, w2 + j, w3 + j);                  \
    for (; j + N <= n && same_high(j, N); j += N)                                                                \
      philox_run_##N<Rounds, 1>(first_pixel + j, k, stream, w0 + j, w1 + j, w2 + j, w3 + j);                    \
    if (j < n) TAIL(key, frame, first_pixel + j, stream, n - j, w0 + j, w1 + j, w2 + j, w3 + j);                 \
  }                                                                                                              \
  __attribute__((target(ISA))) void philox_list_##N(uint64_t key, uint32_t frame, const uint32_t* pixel_lo,       \
                                                    const uint32_t* pixel_hi, uint32_t stream, int n,            \
                                                    uint32_t* w0, uint32_t* w1, uint32_t* w2, uint32_t* w3) {    \
    if (n < N) return;                                                                                           \
    const PhiloxKeys##N<shader::kPhiloxRounds> k(key, frame);                                                    \
    int j = 0;                                                                                                   \
    if constexpr (U > 1)                                                                                         \
      for (; j + U * N <= n; j += U * N) {                                                                       \
        V lo[U], hi[U];                                                                                          \
        for (int b = 0; b < U; ++b) lo[b] = LOAD(pixel_lo + j + b * N), hi[b] = LOAD(pixel_hi + j + b * N);     \
        philox_lanes_##N<shader::kPhiloxRounds, U>(lo, hi, k, stream, w0 + j, w1 + j, w2 + j, w3 + j);           \
      }                                                                                                          \
    for (; j + N <= n; j += N) {                                                                                 \
      const V lo[1] = {LOAD(pixel_lo + j)}, hi[1] = {LOAD(pixel_hi + j)};                                        \
      philox_lanes_##N(lo, hi, k, stream, w0 + j, w1 + j, w2 + j, w3 + j);                                       \
    }                                                                                                            \
  }

#define PHILOX_AVX2_OP(x) _mm256_##x
// The AVX2 path runs four vectors (32 pixels) at once. One vector's round is a chain of ~8
// dependent instructions (shift, 32x32->64 multiply, shift, blend, two xors) for ~16 of them, so
// ten rounds alone wait on latency (~80 cycles for 8 pixels on a Zen 3, where the ~160
// instructions could issue in ~40); four independent chains interleaved round by round fill
// the gaps. Integer operations only: the same words as one vector at a time. A standalone loop
// over 1,024 pixels (2026-11-29, AMD EPYC Zen 3): 3.25 ns a pixel one vector at a time, 2.35 with
// two, 2.12 with four (the four's 16 state registers spill a few keys, still ahead).
constexpr int kPhiloxAvx2Blocks = 4;
// The high halves: the products of the even lanes by mul_epu32, of the odd lanes shifted down the
// same way, put back in place by a shift and a blend. The low halves: one vpmulld (mullo_epi32),
// the low 32 bits of each lane's product, which are the same bits as the 64-bit product's low
// half (multiplication mod 2^32), where a shift and a blend of the two products were two
// instructions. It also takes lo off the chain through the mul_epu32s. A photosite choice for the
// AMD cores the AVX2 cap stands for: on this Zen 4 host (2026-12-01) a standalone loop of
// 1,536 pixels' ten rounds, four vectors interleaved, best of 3,000: 1.89 ns a pixel with the
// shift and blend, 1.65 with vpmulld; `photosite bench sense` at PHOTOSITE_MAX_ISA=avx2, 1 thread,
// row "Philox4x32-10 words, AVX2": 4.12 -> 3.58 ms (docs/benchmarks.md, "Twenty-seventh session:
// the sensor's AVX2 gap"). On Intel cores without AVX-512 (Skylake..) vpmulld is two uops of
// latency 10 (Agner Fog's instruction tables), so there it may not gain (not measured).
#define PHILOX_AVX2_MULHILO(c, m, hi, lo)                                                    \
  do {                                                                                       \
    const __m256i e_ = _mm256_mul_epu32(c, m), o_ = _mm256_mul_epu32(_mm256_srli_epi64(c, 32), m); \
    hi = _mm256_blend_epi32(_mm256_srli_epi64(e_, 32), o_, 0xAA);                            \
    lo = _mm256_mullo_epi32(c, m);                                                           \
  } while (0)
#define PHILOX_AVX2_XOR3(a, b, c) _mm256_xor_si256(_mm256_xor_si256(a, b), c)
#define PHILOX_AVX2_LOAD(p) _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p))
#define PHILOX_AVX2_STORE(p, v) _mm256_storeu_si256(reinterpret_cast<__m256i*>(p), v)
#define PHILOX_AVX2_LANES _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7)
PHILOX_SIMD("avx2", __m256i, 8, kPhiloxAvx2Blocks, PHILOX_AVX2_OP, PHILOX_AVX2_MULHILO, PHILOX_AVX2_XOR3, PHILOX_AVX2_LOAD,
            PHILOX_AVX2_STORE, PHILOX_AVX2_LANES, philox_words_scalar)

// GCC 12's AVX-512 intrinsics pass _mm512_undefined_epi32() as the unused merge source of their
// masked builtins, which -Wmaybe-uninitialized reports at every use (GCC bug 105593, fixed in
// GCC 13): silenced for the AVX-512 functions only.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#define PHILOX_AVX512_OP(x) _mm512_##x
// The AVX-512 path runs four vectors (64 pixels) at once too, for the reason given at
// kPhiloxAvx2Blocks: one vector's round is a dependent chain (shift, 32x32->64 multiply, masked
// swap, three-way xor), and on a core that executes 512-bit operations in two 256-bit halves (AMD
// Zen 4) ten rounds of one vector wait on it. Integer operations only: the same words. Measured
// (`OMP_NUM_THREADS=1 photosite bench sense --repeats 3 --inner 5`, row "Philox4x32-10 words,
// AVX-512", the 2,097,152 pixels' words, CPU ms; AMD EPYC Zen 4, 2026-11-30): one vector 3.42,
// 3.41, 3.49; two 2.85, 2.84, 2.84; three 2.80, 2.81; four 2.62, 2.62, 2.62; six 3.07, 3.08
// (spills: six vectors' 24 state registers and the keys exceed the 32 zmm registers).
constexpr int kPhiloxAvx512Blocks = 4;
// The products of the even lanes by mul_epu32, of the odd lanes shifted down the same way; each
// half put in place by one masked dword swap (vpshufd CDAB under a mask): hi takes the even
// products' high dwords swapped down into the even lanes over the odd products (whose high
// dwords are in the odd lanes already), lo the odd products' low dwords swapped up into the odd
// lanes over the even products. One instruction a half where a shift and a blend were two.
#define PHILOX_AVX512_MULHILO(c, m, hi, lo)                                                  \
  do {                                                                                       \
    const __m512i e_ = _mm512_mul_epu32(c, m), o_ = _mm512_mul_epu32(_mm512_srli_epi64(c, 32), m); \
    hi = _mm512_mask_shuffle_epi32(o_, 0x5555, e_, _MM_PERM_CDAB);                           \
    lo = _mm512_mask_shuffle_epi32(e_, 0xAAAA, o_, _MM_PERM_CDAB);                           \
  } while (0)
#define PHILOX_AVX512_XOR3(a, b, c) _mm512_ternarylogic_epi32(a, b, c, 0x96)
#define PHILOX_AVX512_LOAD(p) _mm512_loadu_si512(p)
#define PHILOX_AVX512_STORE(p, v) _mm512_storeu_si512(p, v)
#define PHILOX_AVX512_LANES _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15)
PHILOX_SIMD("avx512f", __m512i, 16, kPhiloxAvx512Blocks, PHILOX_AVX512_OP, PHILOX_AVX512_MULHILO, PHILOX_AVX512_XOR3,
            PHILOX_AVX512_LOAD, PHILOX_AVX512_STORE, PHILOX_AVX512_LANES, philox_words_8<Rounds>)
#pragma GCC diagnostic pop

const bool kHaveAvx2 = photosite::detail::have_avx2();
const bool kHaveAvx512 = photosite::detail::have_avx512();
// The Philox path the sampler runs: the widest this CPU has, unless a test or the generator
// benchmark narrowed it (detail::set_philox_path). 0 scalar, 1 AVX2, 2 AVX-512.
const int kBestPhiloxPath = kHaveAvx512 ? 2 : kHaveAvx2 ? 1 : 0;
std::atomic<int> g_philox_path{kBestPhiloxPath};

void philox_words(uint64_t key, uint32_t frame, uint64_t first_pixel, uint32_t stream, int n,
                  uint32_t* w0, uint32_t* w1, uint32_t* w2, uint32_t* w3) {
  const int path = g_philox_path.load(std::memory_order_relaxed);
  if (path == 2) philox_words_16(key, frame, first_pixel, stream, n, w0, w1, w2, w3);
  else if (path == 1) philox_words_8(key, frame, first_pixel, stream, n, w0, w1, w2, w3);
  else philox_words_scalar(key, frame, first_pixel, stream, n, w0, w1, w2, w3);
}
void philox_list(uint64_t key, uint32_t frame, const uint32_t* pixel_lo, const uint32_t* pixel_hi,
                 uint32_t stream, int n, uint32_t* w0, uint32_t* w1, uint32_t* w2, uint32_t* w3) {
  const int path = g_philox_path.load(std::memory_order_relaxed);
  int j = 0;
  if (path == 2) philox_list_16(key, frame, pixel_lo, pixel_hi, stream, j = n & ~15, w0, w1, w2, w3);
  if (path >= 1) {
    const int m = (n - j) & ~7;
    philox_list_8(key, frame, pixel_lo + j, pixel_hi + j, stream, m, w0 + j, w1 + j, w2 + j, w3 + j);
    j += m;
  }
  for (; j < n; ++j)
    philox_one(key, frame, (static_cast<uint64_t>(pixel_hi[j]) << 32) | pixel_lo[j], stream, j, w0, w1, w2, w3);
}

// The float loops below carry AVX-512 (16 lanes), AVX2 (8) and baseline clones
// (target_clones), dispatched once by the CPU's features: the same IEEE operations per lane in
// the same order on every clone (no FMA: -ffp-contract=off; sqrt and division correctly
// rounded at any width), so the same bits. Held to the scalar reference (compiled for the
// baseline in the tests) by PoissonAccuracy.PtrsBlockEqualsScalarReference,
// PoissonAccuracy.MixedBlocksEqualScalarReference and Poisson.BlockKernelMatchesScalarPhiloxWords,
// which run the widest clone the CPU has, and by the CPU/Vulkan parity tests.
PHOTOSITE_TARGET_CLONES
void normals(const uint32_t* a, const uint32_t* b, float* z, int n) {
  for (int j = 0; j < n; ++j) z[j] = detail::normal_from_words_f(a[j], b[j]);
}

PHOTOSITE_TARGET_CLONES
void corrected_normal_block(const float* mean, const float* z, float* out, int n) {
  for (int j = 0; j < n; ++j)
    out[j] = detail::cornish_fisher_sample(
        detail::cornish_fisher_setup(std::max(mean[j], static_cast<float>(kPoissonApproxThreshold))), z[j]);
}
// Inversion for the compacted low-mean pixels of a block: K = Σ_k [F(k) < u]. A documented SIMD
// twin of poisson_inversion (kernels/common/poisson_draws.glsl), which stops per lane with a
// break that keeps it from vectorizing: the same sums in the same order, so the same bits, held
// to them by the tests Poisson.BlockKernelMatchesScalarPhiloxWords and
// Philox.PoissonBlockEqualsPerPixelDefinitionOnEveryPathAtOddSizes. The lanes go in groups of
// kInversionLanes, all lanes of a group in step, each group until its own lanes have stopped,
// its state in registers (four AVX-512 vectors: independent chains of multiply and add).
// m is a multiple of kInversionLanes: the caller pads the last group with mean 0, whose lanes
// stop at once (u < 1 = F(0)).
constexpr int kInversionLanes = 64;
static_assert(kBlock % kInversionLanes == 0);
PHOTOSITE_TARGET_CLONES
void inversion_block(const float* mean, const uint32_t* w, float* k_out, int m) {
  if (m % kInversionLanes != 0) __builtin_unreachable();
  for (int i0 = 0; i0 < m; i0 += kInversionLanes) {
    float mu[kInversionLanes], u[kInversionLanes], p[kInversionLanes], cdf[kInversionLanes], k[kInversionLanes];
    for (int i = 0; i < kInversionLanes; ++i) {
      mu[i] = mean[i0 + i];
      u[i] = detail::inversion_uniform(w[i0 + i]);
      p[i] = detail::fast_exp(-mu[i]);
      cdf[i] = p[i];
      k[i] = 0.f;
    }
    for (int j = 1; j < 64; ++j) {
      int active = 0;
      for (int i = 0; i < kInversionLanes; ++i) {
        p[i] *= mu[i] * detail::kInverseInteger[j];
        // Lanes that stopped stay stopped: once u <= cdf it remains so as cdf only grows, and p
        // only shrinks past the mode; k and cdf advance together exactly as in the scalar loop.
        const bool go = u[i] > cdf[i] && p[i] > detail::kInversionMinPmf;
        k[i] += go ? 1.f : 0.f;
        cdf[i] += go ? p[i] : 0.f;
        active += go;
      }
      if (!active) break;
    }
    for (int i = 0; i < kInversionLanes; ++i) k_out[i0 + i] = k[i];
  }
}
// inversion_block on the AVX-512 path (the sampler's, set_philox_path): the set-up loop as
// there (vectorized by GCC), then each group's search with its four vectors of lanes in
// registers and the stop test as one OR of the four lanes' masks (kortest) where GCC summed
// the 64 lanes' flags through a horizontal add every step, about a third of the step's
// instructions. The same operations per lane in the same order (p·(μ·(1/j)), the two compares,
// k + 1 and cdf + p on the lanes that go on: a masked add leaves the others as adding 0 did, k
// and cdf being >= 0), so the same draws (tests Philox.PoissonBlockEqualsPerPixelDefinitionOnEveryPathAtOddSizes,
// Poisson.BlockKernelMatchesScalarPhiloxWords).
__attribute__((target("avx512f")))
void inversion_block_avx512(const float* mean, const uint32_t* w, float* k_out, int m) {
  if (m % kInversionLanes != 0) __builtin_unreachable();
  constexpr int V = kInversionLanes / 16;
  for (int i0 = 0; i0 < m; i0 += kInversionLanes) {
    alignas(64) float u[kInversionLanes], p[kInversionLanes];
    for (int i = 0; i < kInversionLanes; ++i) {
      u[i] = detail::inversion_uniform(w[i0 + i]);
      p[i] = detail::fast_exp(-mean[i0 + i]);
    }
    __m512 vmu[V], vu[V], vp[V], vcdf[V], vk[V];
    for (int v = 0; v < V; ++v) {
      vmu[v] = _mm512_loadu_ps(mean + i0 + 16 * v);
      vu[v] = _mm512_load_ps(u + 16 * v);
      vp[v] = _mm512_load_ps(p + 16 * v);
      vcdf[v] = vp[v];
      vk[v] = _mm512_setzero_ps();
    }
    const __m512 one = _mm512_set1_ps(1.f), min_pmf = _mm512_set1_ps(detail::kInversionMinPmf);
    for (int j = 1; j < 64; ++j) {
      const __m512 inv_j = _mm512_set1_ps(detail::kInverseInteger[j]);
      __mmask16 any = 0;
      for (int v = 0; v < V; ++v) {
        vp[v] = _mm512_mul_ps(vp[v], _mm512_mul_ps(vmu[v], inv_j));
        const __mmask16 go =
            _mm512_mask_cmp_ps_mask(_mm512_cmp_ps_mask(vu[v], vcdf[v], _CMP_GT_OQ), vp[v], min_pmf, _CMP_GT_OQ);
        vk[v] = _mm512_mask_add_ps(vk[v], go, vk[v], one);
        vcdf[v] = _mm512_mask_add_ps(vcdf[v], go, vcdf[v], vp[v]);
        any = static_cast<__mmask16>(any | go);
      }
      if (!any) break;
    }
    for (int v = 0; v < V; ++v) _mm512_storeu_ps(k_out + i0 + 16 * v, vk[v]);
  }
}
// The same on the AVX2 path (GCC's AVX2 clone of inversion_block sums the go flags through a
// horizontal add every step, as its AVX-512 clone did): eight vectors of 8 lanes in registers,
// the stop test one OR of their go masks. cdf + p where a lane goes on, + 0 where it does not
// (the select of inversion_block, then its add), so the same cdf. k is counted in integers, k − go
// (go all ones, −1, where the lane goes on), and converted to float at the end: inversion_block's
// float k, a sum of 1s from 0, is an integer below 64 and so exact, the same value as the
// converted count (exact below 2^24). One AND a vector and step fewer than k + (go & 1).
__attribute__((target("avx2")))
void inversion_block_avx2(const float* mean, const uint32_t* w, float* k_out, int m) {
  if (m % kInversionLanes != 0) __builtin_unreachable();
  constexpr int V = kInversionLanes / 8;
  for (int i0 = 0; i0 < m; i0 += kInversionLanes) {
    alignas(32) float u[kInversionLanes], p[kInversionLanes];
    for (int i = 0; i < kInversionLanes; ++i) {
      u[i] = detail::inversion_uniform(w[i0 + i]);
      p[i] = detail::fast_exp(-mean[i0 + i]);
    }
    __m256 vmu[V], vu[V], vp[V], vcdf[V];
    __m256i vk[V];
    for (int v = 0; v < V; ++v) {
      vmu[v] = _mm256_loadu_ps(mean + i0 + 8 * v);
      vu[v] = _mm256_load_ps(u + 8 * v);
      vp[v] = _mm256_load_ps(p + 8 * v);
      vcdf[v] = vp[v];
      vk[v] = _mm256_setzero_si256();
    }
    const __m256 min_pmf = _mm256_set1_ps(detail::kInversionMinPmf);
    for (int j = 1; j < 64; ++j) {
      const __m256 inv_j = _mm256_set1_ps(detail::kInverseInteger[j]);
      __m256 any = _mm256_setzero_ps();
      for (int v = 0; v < V; ++v) {
        vp[v] = _mm256_mul_ps(vp[v], _mm256_mul_ps(vmu[v], inv_j));
        const __m256 go =
            _mm256_and_ps(_mm256_cmp_ps(vu[v], vcdf[v], _CMP_GT_OQ), _mm256_cmp_ps(vp[v], min_pmf, _CMP_GT_OQ));
        vk[v] = _mm256_sub_epi32(vk[v], _mm256_castps_si256(go));
        vcdf[v] = _mm256_add_ps(vcdf[v], _mm256_and_ps(go, vp[v]));
        any = _mm256_or_ps(any, go);
      }
      if (_mm256_testz_ps(any, any)) break;
    }
    for (int v = 0; v < V; ++v) _mm256_storeu_ps(k_out + i0 + 8 * v, _mm256_cvtepi32_ps(vk[v]));
  }
}
PHOTOSITE_TARGET_CLONES
void rounded_normal(const float* mean, const float* z, float* out, int n) {
  for (int j = 0; j < n; ++j) out[j] = detail::rounded_normal_sample(mean[j], z[j]);
}

// PTRS over a block, in three vector passes with masked retries: (1) every lane's first
// candidate from its own words 0, 1 and the squeeze (lanes below mean 10 run it on 10 and are
// overwritten by the inversion); (2) the full acceptance test on the lanes the squeeze left
// undecided, compacted; (3) the rejected lanes, compacted, retried on their retry streams, two
// attempts per Philox call, until none is left. Compaction is branch-free (select_lanes): the
// verdicts are random, branches on them would mispredict. Each lane's result is
// detail::ptrs_sample's, whatever the block, the thread or the other lanes.
PHOTOSITE_TARGET_CLONES
void ptrs_first(const float* __restrict mean, const uint32_t* __restrict wu, const uint32_t* __restrict wv,
                float* __restrict mu, float* __restrict k, float* __restrict us, float* __restrict v,
                float* __restrict verdict, int m) {
  for (int i = 0; i < m; ++i) {
    const bool high = mean[i] >= static_cast<float>(kPoissonApproxThreshold);
    const float mi = high ? mean[i] : 10.f;
    const detail::PtrsCandidate c = detail::ptrs_candidate(detail::ptrs_setup(mi), wu[i], wv[i]);
    mu[i] = mi;
    k[i] = c.k;
    us[i] = c.us;
    v[i] = c.v;
    verdict[i] = high ? c.verdict : 1.f;  // lanes below 10: left to the inversion
  }
}
// The compacted passes run whole vectors: their counts are rounded up to a multiple of 8 by the
// caller, the extra lanes holding harmless values (pad8), so no lane falls into a scalar
// epilogue loop (an attempt costs ~8x more there).
inline int round8(int n) { return (n + 7) & ~7; }
template <class T>
inline void pad8(T* a, int n, T value) {
  for (int i = n; i < round8(n); ++i) a[i] = value;
}
PHOTOSITE_TARGET_CLONES
void ptrs_full_test(const float* __restrict mu, const float* __restrict k, const float* __restrict us,
                    const float* __restrict v, float* __restrict accepted, int m) {
  if (m % 8 != 0) __builtin_unreachable();
  for (int i = 0; i < m; ++i)
    accepted[i] = detail::ptrs_accept(detail::ptrs_setup(mu[i]), detail::PtrsCandidate{k[i], us[i], v[i], 0.f}) ? 1.f : 0.f;
}
// ptrs_attempts_definition: detail::ptrs_attempt lane by lane, the full test evaluated on every
// lane (branch-free); the twin of ptrs_attempts below (test Philox.PtrsAttemptsEqualTheirDefinition).
PHOTOSITE_TARGET_CLONES
void ptrs_attempts_definition(const float* __restrict mu, const uint32_t* __restrict wu, const uint32_t* __restrict wv,
                              float* __restrict k, int m) {
  if (m % 8 != 0) __builtin_unreachable();
  for (int i = 0; i < m; ++i) k[i] = detail::ptrs_attempt(detail::ptrs_setup(mu[i]), wu[i], wv[i]);
}

// The lanes i < m where keep[i] != 0, in order, into idx (room for m + 8); returns their count.
// Branch-free: the conditions are random, branches on them would mispredict. With AVX2, 8
// lanes at a time: the compare's sign mask picks a precomputed permutation that packs the kept
// lanes' indices to the front ("left-packing"), stored whole, the count advancing by its
// popcount; plain C++ otherwise (every lane writes its index, the count advances by the
// condition).
// The permutations are stored a byte a lane (2 KB, 32 cache lines; widened to 32-bit lanes by one
// vpmovzxbd from memory, the same permutations). As 32-bit lanes the table took 8 KB, 128 lines,
// which the block's arrays (8 KB each) passing through the 32 KiB L1d evict between uses: the
// table's load, on the path from the compare to every permute, held 31 % of pack_lanes_avx2<4>'s
// cpu-clock samples, 21 % from the byte table, and the sampler's glue took fewer samples against
// the unchanged sensor functions in 7 of 7 alternating profiles on the Zen 3 host
// (docs/benchmarks.md, "Thirty-third session: the sensor's Poisson glue").
struct PackTable {
  alignas(64) uint8_t perm[256][8];
  PackTable() {
    for (int mask = 0; mask < 256; ++mask) {
      int n = 0;
      for (int j = 0; j < 8; ++j)
        if (mask >> j & 1) perm[mask][n++] = static_cast<uint8_t>(j);
      for (; n < 8; ++n) perm[mask][n] = 0;
    }
  }
};
const PackTable kPack;
// The permutation of mask's kept lanes, one lane index per 32-bit lane.
__attribute__((target("avx2"), always_inline)) inline __m256i pack_perm_avx2(int mask) {
  return _mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(kPack.perm[mask])));
}
__attribute__((target("avx2")))
int select_lanes_avx2(const float* keep, int m, int* idx) {
  int n = 0, i = 0;
  for (; i + 8 <= m; i += 8) {
    const int mask = _mm256_movemask_ps(_mm256_cmp_ps(_mm256_loadu_ps(keep + i), _mm256_setzero_ps(), _CMP_NEQ_UQ));
    const __m256i perm = pack_perm_avx2(mask);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(idx + n), _mm256_add_epi32(perm, _mm256_set1_epi32(i)));
    n += __builtin_popcount(static_cast<unsigned>(mask));
  }
  for (; i < m; ++i) {
    idx[n] = i;
    n += keep[i] != 0.f ? 1 : 0;
  }
  return n;
}
int select_lanes(const float* keep, int m, int* idx) {
  if (kHaveAvx2) return select_lanes_avx2(keep, m, idx);
  int n = 0;
  for (int i = 0; i < m; ++i) {
    idx[n] = i;
    n += keep[i] != 0.f ? 1 : 0;
  }
  return n;
}

// pack_lanes: the lanes i < m where keep[i] != 0, in order, their indices into idx and, for
// each LaneCopy, their 32-bit values (floats or words) from src[i] into dst[0, count);
// returns the count. idx and every dst hold m + kPackRoom lanes (whole vectors are stored past
// the count). A dst may be its own src (packing in place): every path moves lane i to a place
// <= i in increasing order, and the vector paths' store for a group of 16 (8) lanes from i
// reaches at most lane i + 15 (i + 7), which that group has already read. On the AVX-512 path
// (the sampler's vector path, set_philox_path) one vpcompressd per array and 16 lanes packs the
// values with the indices, the mask from one compare; on the AVX2 path one permute per array and
// 8 lanes (pack_lanes_avx2); on the scalar path select_lanes' indices, then a gather per array. Copies only, the same
// lanes in the same order on every path, so no draw depends on the path (test
// Philox.PoissonDrawsEqualOnEveryPathAndThreadCount).
constexpr int kPackRoom = 16;
struct LaneCopy {
  const void* src;
  void* dst;
};
// NC, the number of arrays, is a template argument: the copy loop unrolls with every source and
// destination pointer in a register (a run-time count reloaded both pointers from the list and
// advanced them for every array of every 16 lanes).
template <int NC>
__attribute__((target("avx512f")))
int pack_lanes_avx512(const float* keep, int m, int* idx, const LaneCopy (&copies)[NC]) {
  const uint32_t* src[NC];
  uint32_t* dst[NC];
  for (int c = 0; c < NC; ++c) {
    // One 8-byte load per pointer (the empty asm keeps GCC from loading the caller's list, just
    // stored pointer by pointer, as 32-byte vectors that its stores cannot forward to).
    const void* s = copies[c].src;
    void* d = copies[c].dst;
    asm("" : "+r"(s), "+r"(d));
    src[c] = static_cast<const uint32_t*>(s);
    dst[c] = static_cast<uint32_t*>(d);
  }
  const __m512i iota = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  int n = 0;
  for (int i = 0; i < m; i += 16) {
    // The last group's lanes past m are neither read nor kept (masked loads do not fault).
    const __mmask16 valid = m - i >= 16 ? __mmask16(0xffff) : static_cast<__mmask16>((1u << (m - i)) - 1);
    const __mmask16 k =
        _mm512_mask_cmp_ps_mask(valid, _mm512_maskz_loadu_ps(valid, keep + i), _mm512_setzero_ps(), _CMP_NEQ_UQ);
    _mm512_storeu_si512(idx + n, _mm512_maskz_compress_epi32(k, _mm512_add_epi32(iota, _mm512_set1_epi32(i))));
#pragma GCC unroll 8
    for (int c = 0; c < NC; ++c) {
      const __m512i v = _mm512_maskz_loadu_epi32(k, src[c] + i);
      _mm512_storeu_si512(dst[c] + n, _mm512_maskz_compress_epi32(k, v));
    }
    n += __builtin_popcount(static_cast<unsigned>(k));
  }
  return n;
}
// One group of pack_lanes_avx2: 8 lanes from i, n advanced by the kept ones. Full: all 8 below
// m, read by plain loads (vmaskmov loads are slower: on AMD Zen 3 and 4 one per cycle against
// two or three plain loads, uops.info); else the last group, by masked loads. The same lanes
// either way.
template <bool Full, int NC>
__attribute__((target("avx2"), always_inline)) inline void pack_group_avx2(const float* keep, int m, int i, int* idx,
                                                                           const uint32_t* const (&src)[NC],
                                                                           uint32_t* const (&dst)[NC], int& n) {
  const __m256i valid = _mm256_cmpgt_epi32(_mm256_set1_epi32(m - i), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
  const __m256 kv = Full ? _mm256_loadu_ps(keep + i) : _mm256_maskload_ps(keep + i, valid);  // lanes i + l < m
  const __m256 kept = _mm256_cmp_ps(kv, _mm256_setzero_ps(), _CMP_NEQ_UQ);
  const int mask = _mm256_movemask_ps(Full ? kept : _mm256_and_ps(_mm256_castsi256_ps(valid), kept));
  const __m256i perm = pack_perm_avx2(mask);
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(idx + n), _mm256_add_epi32(perm, _mm256_set1_epi32(i)));
#pragma GCC unroll 8
  for (int c = 0; c < NC; ++c) {
    const int* sc = reinterpret_cast<const int*>(src[c] + i);
    const __m256i v = Full ? _mm256_loadu_si256(reinterpret_cast<const __m256i*>(sc)) : _mm256_maskload_epi32(sc, valid);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(dst[c] + n), _mm256_permutevar8x32_epi32(v, perm));
  }
  n += __builtin_popcount(static_cast<unsigned>(mask));
}
// The same on the AVX2 path, 8 lanes at a time: the compare's sign mask picks select_lanes'
// left-packing permutation (kPack), which moves the kept lanes' indices and each array's values
// to the front of the vector, stored whole at the count (AVX2 has no compress); the last group's
// lanes past m are neither read (masked loads do not fault) nor kept. The same lanes in the same
// order as the other paths; in place as safe as there (a group's stores reach no lane past its
// own, which it has read).
template <int NC>
__attribute__((target("avx2")))
int pack_lanes_avx2(const float* keep, int m, int* idx, const LaneCopy (&copies)[NC]) {
  const uint32_t* src[NC];
  uint32_t* dst[NC];
  for (int c = 0; c < NC; ++c) {
    const void* s = copies[c].src;
    void* d = copies[c].dst;
    asm("" : "+r"(s), "+r"(d));  // as in pack_lanes_avx512
    src[c] = static_cast<const uint32_t*>(s);
    dst[c] = static_cast<uint32_t*>(d);
  }
  int n = 0;
  int i = 0;
  for (; i + 8 <= m; i += 8) pack_group_avx2<true, NC>(keep, m, i, idx, src, dst, n);
  if (i < m) pack_group_avx2<false, NC>(keep, m, i, idx, src, dst, n);
  return n;
}
template <int NC>
int pack_lanes(const float* keep, int m, int* idx, const LaneCopy (&copies)[NC]) {
  const int path = g_philox_path.load(std::memory_order_relaxed);
  if (path == 2) return pack_lanes_avx512<NC>(keep, m, idx, copies);
  if (path == 1) return pack_lanes_avx2<NC>(keep, m, idx, copies);
  const int n = select_lanes(keep, m, idx);
  for (const LaneCopy& c : copies)
    for (int j = 0; j < n; ++j)
      std::memmove(static_cast<char*>(c.dst) + 4 * static_cast<size_t>(j),
                  static_cast<const char*>(c.src) + 4 * static_cast<size_t>(idx[j]), 4);
  return n;
}

// The first PTRS attempt over m lanes (m a multiple of 8, m <= kBlock), in two passes: (1) every
// lane's candidate from its words wu, wv and the squeeze (ptrs_first: mu, and the candidate k, for
// lanes below mean 10 run on 10 and accepted, left to the inversion); (2) the full acceptance test
// only on the lanes the squeeze left undecided (verdict 0: 609,780 of the 1,580,389 first attempts
// of a night frame, docs/benchmarks.md), compacted. rejected[i]: 1 where the attempt failed, else 0.
// AVX-512 and AVX2 clones for its own loops (the verdict's flags, the scatter of the full test's
// verdicts: compares and copies), as ptrs_block.
PHOTOSITE_TARGET_CLONES
void ptrs_first_attempt(const float* mean, const uint32_t* wu, const uint32_t* wv, float* mu, float* k,
                        float* rejected, int m) {
  constexpr int R = kBlock + kPackRoom;  // pack_lanes' destinations
  alignas(64) float undecided[kBlock], acc[kBlock];
  alignas(64) float cmu[R], ck[R], cus[R], cv[R];
  alignas(64) float us[kBlock], v[kBlock];
  alignas(64) int sel[R];
  ptrs_first(mean, wu, wv, mu, k, us, v, rejected, m);
  for (int i = 0; i < m; ++i) {
    undecided[i] = rejected[i] == 0.f ? 1.f : 0.f;
    rejected[i] = rejected[i] < 0.f ? 1.f : 0.f;
  }
  const int nu = pack_lanes(undecided, m, sel, {{mu, cmu}, {k, ck}, {us, cus}, {v, cv}});
  pad8(cmu, nu, 10.f), pad8(ck, nu, 10.f), pad8(cus, nu, 0.5f), pad8(cv, nu, 0.5f);
  ptrs_full_test(cmu, ck, cus, cv, acc, round8(nu));
  for (int j = 0; j < nu; ++j) rejected[sel[j]] = 1.f - acc[j];
}
// detail::ptrs_attempt over m lanes (m a multiple of 8, m <= kBlock; every mu >= 10, the PTRS
// lanes' and pad8's): k[i] >= 0 accepted, −1 rejected, by ptrs_first_attempt (the full test only
// on the undecided lanes). ptrs_attempt evaluates the full test on every lane and keeps it where
// the verdict is 0: the same k for every lane, since the full test of a lane is the same function
// of the same (mu, k, u_s, v) wherever it runs.
void ptrs_attempts(const float* mu, const uint32_t* wu, const uint32_t* wv, float* k, int m) {
  alignas(64) float mu_kept[kBlock], rejected[kBlock];
  ptrs_first_attempt(mu, wu, wv, mu_kept, k, rejected, m);
  for (int i = 0; i < m; ++i) k[i] = rejected[i] != 0.f ? -1.f : k[i];
}

// out[i] = the PTRS draw for every lane i of the block whose mean is >= 10 (pixel
// first_pixel + lane[i], or first_pixel + i when lane is null; own words w0[i], w1[i]); other
// lanes get a value the caller overwrites. AVX-512 and AVX2 clones for its own loops (verdict flags,
// gathers and scatters of the compacted lanes: copies and compares, no arithmetic on the draws).
// GCC's -Wmaybe-uninitialized cannot see that pad8 fills the lanes [n, round8(n)) that the
// whole-vector passes read past the n compacted ones; every lane read is written first.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
PHOTOSITE_TARGET_CLONES
void ptrs_block(const float* mean, const uint32_t* w0, const uint32_t* w1, int m, float* out, uint64_t first_pixel,
                uint64_t key, uint32_t frame, uint32_t stream, const int* lane = nullptr) {
  constexpr int R = kBlock + kPackRoom;  // pack_lanes' destinations
  alignas(64) float mu[kBlock], rejected[kBlock];
  alignas(64) float cmu[R], ck[R], cv[R];
  alignas(64) int sel[R], sel2[R];
  // Passes 1 and 2: every lane's first attempt, k straight into out.
  ptrs_first_attempt(mean, w0, w1, mu, out, rejected, m);
  // Pass 3: the rejected lanes retried, compacted, until each is accepted: per retry call, the
  // first attempt on all of them, the second on those the first rejected.
  alignas(64) uint32_t plo[R], phi[R], r0[kBlock], r1[kBlock], r2[kBlock], r3[kBlock], q2[R], q3[R];
  alignas(64) float qmu[R], again[kBlock];
  int nr = pack_lanes(rejected, m, sel, {{mu, cmu}});
  for (int j = 0; j < nr; ++j) {
    const uint64_t pixel = first_pixel + static_cast<uint64_t>(lane ? lane[sel[j]] : sel[j]);
    plo[j] = static_cast<uint32_t>(pixel);
    phi[j] = static_cast<uint32_t>(pixel >> 32);
  }
  for (int r = 1; nr > 0 && r <= detail::kPtrsMaxRetryCalls; ++r) {
    pad8(cmu, nr, 10.f), pad8(plo, nr, 0u), pad8(phi, nr, 0u);
    philox_list(key, frame, plo, phi, detail::ptrs_retry_stream(stream, r), round8(nr), r0, r1, r2, r3);
    ptrs_attempts(cmu, r0, r1, ck, round8(nr));
    for (int j = 0; j < nr; ++j) again[j] = ck[j] < 0.f ? 1.f : 0.f;
    const int n2 = pack_lanes(again, nr, sel2, {{cmu, qmu}, {r2, q2}, {r3, q3}});
    pad8(qmu, n2, 10.f), pad8(q2, n2, 0u), pad8(q3, n2, 0u);
    ptrs_attempts(qmu, q2, q3, cv, round8(n2));
    for (int t = 0; t < n2; ++t) ck[sel2[t]] = cv[t];
    // (Two loops: in one, GCC made the select a branch on the random verdicts.)
    for (int j = 0; j < nr; ++j) out[sel[j]] = ck[j];  // a lane still rejected (k < 0) is written again later
    for (int j = 0; j < nr; ++j) again[j] = ck[j] < 0.f ? 1.f : 0.f;
    // The lanes still rejected, packed in place (pack_lanes allows it: lane j moves to a place
    // <= j, and a group's whole-vector stores reach no lane past those it has read).
    nr = pack_lanes(again, nr, sel2, {{sel, sel}, {cmu, cmu}, {plo, plo}, {phi, phi}});
  }
  for (int j = 0; j < nr; ++j) out[sel[j]] = std::floor(cmu[j]);  // P < 1e-37 (ptrs.glsl)
}
#pragma GCC diagnostic pop
// How many of a[0, n) are >= t (a vectorized count: it runs on every block).
PHOTOSITE_TARGET_CLONES
int count_at_least(const float* __restrict a, int n, float t) {
  int count = 0;
  for (int i = 0; i < n; ++i) count += a[i] >= t ? 1 : 0;
  return count;
}

// ptrs_block on the lanes of a block whose mean is >= 10 (the rest are the inversion's): none,
// skipped; more than half (the common case on the night bench frame, where dark current and
// sky glow lift most pixels above 10 e-), in place on every lane; a few, gathered, drawn with
// their own pixel indices, and scattered back (a dark block with some lit pixels: PTRS's first
// attempt costs a square root and three divisions a lane). Each lane's draw depends on its
// mean, words and pixel alone, so neither choice changes a result.
void ptrs_high_lanes(const float* mean, const uint32_t* w0, const uint32_t* w1, int m, float* out,
                     uint64_t first_pixel, uint64_t key, uint32_t frame, uint32_t stream) {
  constexpr int R = kBlock + kPackRoom;  // pack_lanes' destinations
  alignas(64) float high[kBlock], hmean[R], hout[kBlock];
  alignas(64) uint32_t hw0[R], hw1[R];
  alignas(64) int idx[R];
  const float threshold = static_cast<float>(kPoissonApproxThreshold);
  const int count = count_at_least(mean, m, threshold);
  if (count == 0) return;
  if (2 * count > m) {
    ptrs_block(mean, w0, w1, m, out, first_pixel, key, frame, stream);
    return;
  }
  for (int i = 0; i < m; ++i) high[i] = mean[i] >= threshold ? 1.f : 0.f;
  const int nh = pack_lanes(high, m, idx, {{mean, hmean}, {w0, hw0}, {w1, hw1}});
  ptrs_block(hmean, hw0, hw1, nh, hout, first_pixel, key, frame, stream, idx);
  for (int j = 0; j < nh; ++j) out[idx[j]] = hout[j];
}
}  // namespace

void detail::ptrs_attempt_lanes(bool squeeze_first, const float* mu, const uint32_t* wu, const uint32_t* wv, float* k,
                                int m) {
  if (m % 8 != 0 || m > kBlock) fail("ptrs_attempt_lanes: m must be a multiple of 8 up to the block size");
  if (squeeze_first) ptrs_attempts(mu, wu, wv, k, m);
  else ptrs_attempts_definition(mu, wu, wv, k, m);
}

int detail::pack_lanes_for_test(const float* keep, int m, int* idx, const float* src, float* dst) {
  static_assert(kPackLanesRoom == kPackRoom);
  return pack_lanes(keep, m, idx, {{src, dst}});
}

// AVX-512 and AVX2 clones for its own loops (the lane selections and the low-mean gathers:
// compares and copies, no arithmetic on the draws), so the same bits on every clone.
PHOTOSITE_TARGET_CLONES
void poisson_block(const float* mean, float* out, float* normal2, int n, uint64_t first_pixel,
                   uint64_t key, uint32_t frame, uint32_t stream, PoissonMethod method) {
  alignas(64) uint32_t w0[kBlock], w1[kBlock], w2[kBlock], w3[kBlock];
  alignas(64) float z[kBlock];
  const float threshold = static_cast<float>(kPoissonApproxThreshold);
  for (int start = 0; start < n; start += kBlock) {
    const int m = std::min(kBlock, n - start);
    const float* mu = mean + start;
    float* o = out + start;
    philox_words(key, frame, first_pixel + start, stream, m, w0, w1, w2, w3);
    if (normal2) normals(w2, w3, normal2 + start, m);
    if (method == PoissonMethod::Normal) {
      normals(w0, w1, z, m);
      rounded_normal(mu, z, o, m);
      continue;
    }
    // Means >= 10: PTRS (exact) or the corrected normal (cornish-fisher), on every lane.
    if (method == PoissonMethod::CornishFisher) {
      normals(w0, w1, z, m);
      corrected_normal_block(mu, z, o, m);
    } else {
      ptrs_high_lanes(mu, w0, w1, m, o, first_pixel + start, key, frame, stream);
    }
    // Means below 10: exact inversion on word 0, on the compacted low-mean lanes; zero,
    // negative or NaN means: no electrons.
    for (int j = 0; j < m; ++j) o[j] = mu[j] >= threshold ? o[j] : 0.f;
    alignas(64) float low_mean[kBlock + kPackRoom], low_k[kBlock];
    alignas(64) uint32_t low_w[kBlock + kPackRoom];
    alignas(64) int low_idx[kBlock + kPackRoom];
    for (int j = 0; j < m; ++j) z[j] = (mu[j] < threshold) & (mu[j] > 0.f) ? 1.f : 0.f;
    const int nl = pack_lanes(z, m, low_idx, {{mu, low_mean}, {w0, low_w}});
    if (nl) {
      const int padded = (nl + kInversionLanes - 1) / kInversionLanes * kInversionLanes;  // <= kBlock
      for (int i = nl; i < padded; ++i) low_mean[i] = 0.f, low_w[i] = 0u;
      const int path = g_philox_path.load(std::memory_order_relaxed);
      if (path == 2) inversion_block_avx512(low_mean, low_w, low_k, padded);
      else if (path == 1) inversion_block_avx2(low_mean, low_w, low_k, padded);
      else inversion_block(low_mean, low_w, low_k, padded);
      for (int i = 0; i < nl; ++i) o[low_idx[i]] = low_k[i];
    }
  }
}

detail::PhiloxPath detail::set_philox_path(PhiloxPath path) {
  const int p = std::min(static_cast<int>(path), kBestPhiloxPath);
  return static_cast<PhiloxPath>(g_philox_path.exchange(p));
}
detail::PhiloxPath detail::best_philox_path() { return static_cast<PhiloxPath>(kBestPhiloxPath); }

void detail::philox_block_words(PhiloxPath path, uint64_t key, uint32_t frame, uint64_t first_pixel, uint32_t stream,
                                int n, uint32_t* w0, uint32_t* w1, uint32_t* w2, uint32_t* w3) {
  if (static_cast<int>(path) > kBestPhiloxPath) fail("philox_block_words: this CPU lacks the path");
  if (path == PhiloxPath::Avx512) philox_words_16(key, frame, first_pixel, stream, n, w0, w1, w2, w3);
  else if (path == PhiloxPath::Avx2) philox_words_8(key, frame, first_pixel, stream, n, w0, w1, w2, w3);
  else philox_words_scalar(key, frame, first_pixel, stream, n, w0, w1, w2, w3);
}

void detail::philox_words_rounds(int rounds, PhiloxPath path, uint64_t key, uint32_t frame, uint64_t first_pixel,
                                 uint32_t stream, int n, uint32_t* w0, uint32_t* w1, uint32_t* w2, uint32_t* w3) {
  if (rounds != 7 && rounds != shader::kPhiloxRounds) fail("philox_words_rounds: 7 or 10 rounds");
  if (path == PhiloxPath::Scalar || static_cast<int>(path) > kBestPhiloxPath)
    fail("philox_words_rounds: an AVX2 or AVX-512 path this CPU has");
  if (path == PhiloxPath::Avx512) {
    if (rounds == 7) philox_words_16<7>(key, frame, first_pixel, stream, n, w0, w1, w2, w3);
    else philox_words_16<shader::kPhiloxRounds>(key, frame, first_pixel, stream, n, w0, w1, w2, w3);
  } else {
    if (rounds == 7) philox_words_8<7>(key, frame, first_pixel, stream, n, w0, w1, w2, w3);
    else philox_words_8<shader::kPhiloxRounds>(key, frame, first_pixel, stream, n, w0, w1, w2, w3);
  }
}

float poisson_sample(double mean, uint64_t seed, uint32_t frame, uint64_t pixel, uint32_t stream,
                     PoissonMethod method) {
  const float m = static_cast<float>(mean);
  float out;
  poisson_block(&m, &out, nullptr, 1, pixel, seed, frame, stream, method);
  return out;
}

void poisson_fill(const float* mean, float* out, uint64_t n, uint64_t first_pixel, uint64_t seed,
                  uint32_t frame, uint32_t stream, PoissonMethod method) {
  const int64_t chunks = static_cast<int64_t>((n + 4095) / 4096);
#pragma omp parallel for schedule(static)
  for (int64_t c = 0; c < chunks; ++c) {
    const uint64_t s = static_cast<uint64_t>(c) * 4096, len = std::min<uint64_t>(4096, n - s);
    poisson_block(mean + s, out + s, nullptr, static_cast<int>(len), first_pixel + s, seed, frame, stream, method);
  }
}

namespace {
constexpr std::pair<PoissonMethod, const char*> kPoissonNames[] = {
    {PoissonMethod::Exact, "exact"}, {PoissonMethod::CornishFisher, "cornish-fisher"}, {PoissonMethod::Normal, "normal"}};
}
const char* to_string(PoissonMethod m) {
  for (const auto& [method, name] : kPoissonNames)
    if (method == m) return name;
  return "?";
}
PoissonMethod parse_poisson_method(const std::string& name) {
  for (const auto& [method, n] : kPoissonNames)
    if (name == n) return method;
  fail("unknown Poisson method '" + name + "' (known: exact, cornish-fisher, normal)");
}

}  // namespace photosite
