#include "photosite/sensor/poisson.h"

#include <array>
#include <cmath>
#include <cstring>
#include <immintrin.h>

#include "photosite/sensor/poisson_detail.h"

namespace photosite {
namespace detail {

const float kInverseInteger[64] = {
    0,         1.f / 1,  1.f / 2,  1.f / 3,  1.f / 4,  1.f / 5,  1.f / 6,  1.f / 7,  1.f / 8,
    1.f / 9,   1.f / 10, 1.f / 11, 1.f / 12, 1.f / 13, 1.f / 14, 1.f / 15, 1.f / 16, 1.f / 17,
    1.f / 18,  1.f / 19, 1.f / 20, 1.f / 21, 1.f / 22, 1.f / 23, 1.f / 24, 1.f / 25, 1.f / 26,
    1.f / 27,  1.f / 28, 1.f / 29, 1.f / 30, 1.f / 31, 1.f / 32, 1.f / 33, 1.f / 34, 1.f / 35,
    1.f / 36,  1.f / 37, 1.f / 38, 1.f / 39, 1.f / 40, 1.f / 41, 1.f / 42, 1.f / 43, 1.f / 44,
    1.f / 45,  1.f / 46, 1.f / 47, 1.f / 48, 1.f / 49, 1.f / 50, 1.f / 51, 1.f / 52, 1.f / 53,
    1.f / 54,  1.f / 55, 1.f / 56, 1.f / 57, 1.f / 58, 1.f / 59, 1.f / 60, 1.f / 61, 1.f / 62,
    1.f / 63};

}  // namespace detail

namespace {
constexpr int kBlock = 256;

// Philox4x32-10 over a block of consecutive pixels, bit-identical to rng.h's scalar Philox.
void philox_words_scalar(uint64_t key, uint32_t frame, uint64_t first_pixel, uint32_t stream, int n,
                         uint32_t* w0, uint32_t* w1, uint32_t* w2, uint32_t* w3) {
  for (int j = 0; j < n; ++j) {
    const auto w = random_words(key, frame, first_pixel + j, static_cast<Stream>(stream));
    w0[j] = w[0];
    w1[j] = w[1];
    w2[j] = w[2];
    w3[j] = w[3];
  }
}

// The same, 8 pixels at a time with AVX2: _mm256_mul_epu32 forms the 32x32->64 products of the
// even lanes; the odd lanes are shifted down and multiplied the same way, and blends put the
// high and low halves back in place.
__attribute__((target("avx2")))
void philox_words_avx2(uint64_t key, uint32_t frame, uint64_t first_pixel, uint32_t stream, int n,
                       uint32_t* w0, uint32_t* w1, uint32_t* w2, uint32_t* w3) {
  const __m256i m0 = _mm256_set1_epi32(static_cast<int>(Philox4x32::M0));
  const __m256i m1 = _mm256_set1_epi32(static_cast<int>(Philox4x32::M1));
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  int j = 0;
  for (; j + 8 <= n && ((first_pixel + j) >> 32) == ((first_pixel + j + 7) >> 32); j += 8) {
    const uint64_t p = first_pixel + j;
    __m256i c0 = _mm256_add_epi32(_mm256_set1_epi32(static_cast<int>(static_cast<uint32_t>(p))), lane);
    __m256i c1 = _mm256_set1_epi32(static_cast<int>(static_cast<uint32_t>(p >> 32)));
    __m256i c2 = _mm256_set1_epi32(static_cast<int>(frame));
    __m256i c3 = _mm256_set1_epi32(static_cast<int>(stream));
    uint32_t ka = static_cast<uint32_t>(key), kb = static_cast<uint32_t>(key >> 32);
    for (int r = 0; r < 10; ++r) {
      const __m256i e0 = _mm256_mul_epu32(c0, m0), o0 = _mm256_mul_epu32(_mm256_srli_epi64(c0, 32), m0);
      const __m256i e1 = _mm256_mul_epu32(c2, m1), o1 = _mm256_mul_epu32(_mm256_srli_epi64(c2, 32), m1);
      const __m256i hi0 = _mm256_blend_epi32(_mm256_srli_epi64(e0, 32), o0, 0xAA);
      const __m256i lo0 = _mm256_blend_epi32(e0, _mm256_slli_epi64(o0, 32), 0xAA);
      const __m256i hi1 = _mm256_blend_epi32(_mm256_srli_epi64(e1, 32), o1, 0xAA);
      const __m256i lo1 = _mm256_blend_epi32(e1, _mm256_slli_epi64(o1, 32), 0xAA);
      const __m256i n0 = _mm256_xor_si256(_mm256_xor_si256(hi1, c1), _mm256_set1_epi32(static_cast<int>(ka)));
      const __m256i n2 = _mm256_xor_si256(_mm256_xor_si256(hi0, c3), _mm256_set1_epi32(static_cast<int>(kb)));
      c0 = n0;
      c1 = lo1;
      c2 = n2;
      c3 = lo0;
      ka += Philox4x32::W0;
      kb += Philox4x32::W1;
    }
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(w0 + j), c0);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(w1 + j), c1);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(w2 + j), c2);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(w3 + j), c3);
  }
  if (j < n) philox_words_scalar(key, frame, first_pixel + j, stream, n - j, w0 + j, w1 + j, w2 + j, w3 + j);
}

const bool kHaveAvx2 = __builtin_cpu_supports("avx2");

void philox_words(uint64_t key, uint32_t frame, uint64_t first_pixel, uint32_t stream, int n,
                  uint32_t* w0, uint32_t* w1, uint32_t* w2, uint32_t* w3) {
  if (kHaveAvx2) philox_words_avx2(key, frame, first_pixel, stream, n, w0, w1, w2, w3);
  else philox_words_scalar(key, frame, first_pixel, stream, n, w0, w1, w2, w3);
}

__attribute__((target_clones("avx2", "default")))
void normals(const uint32_t* a, const uint32_t* b, float* z, int n) {
  for (int j = 0; j < n; ++j) z[j] = detail::normal_from_words_f(a[j], b[j]);
}

__attribute__((target_clones("avx2", "default")))
void corrected_normal_block(const float* mean, const float* z, float* out, int n) {
  for (int j = 0; j < n; ++j)
    out[j] = static_cast<float>(
        detail::CornishFisher(std::max(mean[j], static_cast<float>(kPoissonApproxThreshold))).sample(z[j]));
}
// Inversion for the compacted low-mean pixels of a block, all lanes in step: K = Σ_k [F(k) < u],
// the same sums in the same order as detail::poisson_inversion, so the same bits.
__attribute__((target_clones("avx2", "default")))
void inversion_block(const float* mean, const uint32_t* w, float* k_out, int m) {
  alignas(64) float u[kBlock], p[kBlock], cdf[kBlock], k[kBlock];
  for (int i = 0; i < m; ++i) {
    u[i] = detail::inversion_uniform(w[i]);
    p[i] = detail::fast_exp(-mean[i]);
    cdf[i] = p[i];
    k[i] = 0.f;
  }
  for (int j = 1; j < 64; ++j) {
    int active = 0;
    for (int i = 0; i < m; ++i) {
      p[i] *= mean[i] * detail::kInverseInteger[j];
      // Lanes that stopped stay stopped: once u <= cdf it remains so as cdf only grows, and p
      // only shrinks past the mode; k and cdf advance together exactly as in the scalar loop.
      const bool go = u[i] > cdf[i] && p[i] > detail::kInversionMinPmf;
      k[i] += go ? 1.f : 0.f;
      cdf[i] += go ? p[i] : 0.f;
      active += go;
    }
    if (!active) break;
  }
  for (int i = 0; i < m; ++i) k_out[i] = k[i];
}
__attribute__((target_clones("avx2", "default")))
void rounded_normal(const float* mean, const float* z, float* out, int n) {
  for (int j = 0; j < n; ++j) {
    const float mu = std::max(mean[j], 0.f);
    out[j] = std::max(0.f, std::floor(mu + std::sqrt(mu) * z[j] + 0.5f));
  }
}
}  // namespace

void poisson_block(const float* mean, float* out, float* normal2, int n, uint64_t first_pixel,
                   uint64_t key, uint32_t frame, uint32_t stream) {
  alignas(64) uint32_t w0[kBlock], w1[kBlock], w2[kBlock], w3[kBlock];
  alignas(64) float z[kBlock];
  for (int start = 0; start < n; start += kBlock) {
    const int m = std::min(kBlock, n - start);
    philox_words(key, frame, first_pixel + start, stream, m, w0, w1, w2, w3);
    normals(w0, w1, z, m);
    corrected_normal_block(mean + start, z, out + start, m);
    if (normal2) normals(w2, w3, normal2 + start, m);
    // Low means: exact inversion on word 0, on the compacted low-mean pixels.
    alignas(64) float low_mean[kBlock], low_k[kBlock];
    alignas(64) uint32_t low_w[kBlock];
    alignas(64) int low_idx[kBlock];
    int nl = 0;
    for (int j = 0; j < m; ++j) {
      const float mu = mean[start + j];
      if (!(mu >= static_cast<float>(kPoissonApproxThreshold))) {
        if (mu > 0) {
          low_mean[nl] = mu;
          low_w[nl] = w0[j];
          low_idx[nl++] = j;
        } else {
          out[start + j] = 0.f;  // zero, negative or NaN mean: no electrons
        }
      }
    }
    if (nl) {
      inversion_block(low_mean, low_w, low_k, nl);
      for (int i = 0; i < nl; ++i) out[start + low_idx[i]] = low_k[i];
    }
  }
}

float poisson_sample(double mean, uint64_t seed, uint32_t frame, uint64_t pixel, uint32_t stream,
                     PoissonMethod method) {
  const auto w = random_words(seed, frame, pixel, static_cast<Stream>(stream));
  if (method == PoissonMethod::Normal) {
    const float mu = std::max(static_cast<float>(mean), 0.f);
    return std::max(0.f, std::floor(mu + std::sqrt(mu) * detail::normal_from_words_f(w[0], w[1]) + 0.5f));
  }
  const float m = static_cast<float>(mean);
  float out;
  poisson_block(&m, &out, nullptr, 1, pixel, seed, frame, stream);
  return out;
}

void poisson_fill(const float* mean, float* out, uint64_t n, uint64_t first_pixel, uint64_t seed,
                  uint32_t frame, uint32_t stream, PoissonMethod method) {
  const int64_t chunks = static_cast<int64_t>((n + 4095) / 4096);
#pragma omp parallel for schedule(static)
  for (int64_t c = 0; c < chunks; ++c) {
    const uint64_t s = static_cast<uint64_t>(c) * 4096, len = std::min<uint64_t>(4096, n - s);
    if (method == PoissonMethod::Exact) {
      poisson_block(mean + s, out + s, nullptr, static_cast<int>(len), first_pixel + s, seed, frame, stream);
    } else {  // the plain rounded normal, on the same vectorized words (a peer in bench noise)
      alignas(64) uint32_t w0[kBlock], w1[kBlock], w2[kBlock], w3[kBlock];
      alignas(64) float z[kBlock];
      for (uint64_t b = s; b < s + len; b += kBlock) {
        const int m = static_cast<int>(std::min<uint64_t>(kBlock, s + len - b));
        philox_words(seed, frame, first_pixel + b, stream, m, w0, w1, w2, w3);
        normals(w0, w1, z, m);
        rounded_normal(mean + b, z, out + b, m);
      }
    }
  }
}

}  // namespace photosite
