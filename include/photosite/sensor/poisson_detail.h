// The per-pixel Poisson samplers, shared by the sensor loop, the benchmark and the tests.
// PoissonMethod (poisson.h) picks one of three:
//  * exact: below mean kPoissonApproxThreshold (10) inversion by sequential search on a 24-bit
//    uniform (exact up to the 2^-24 grid of the uniform); from 10 up Hörmann's PTRS, an exact
//    rejection sampler (kernels/common/ptrs.glsl has the maths; that one file is compiled into
//    this header and into the Vulkan kernels);
//  * cornish-fisher: the same inversion below 10; above, a Cornish-Fisher quantile of the
//    continuity-corrected Poisson law, an APPROXIMATION. For a lattice variable K,
//    P(K <= k) = P(Y < k + 1/2) where Y is K smoothed over one lattice step; the
//    Sheppard-corrected cumulants of that smooth law are κ₂ = μ − 1/12, κ₃ = μ, κ₄ = μ + 1/120,
//    κ₅ = μ, and the third-order Cornish-Fisher expansion (Cornish & Fisher 1937; Abramowitz &
//    Stegun 26.2.49) gives
//      x = z + γ₁He₂/6 + γ₂He₃/24 − γ₁²(2z³−5z)/36 + γ₃He₄/120 − γ₁γ₂(z⁴−5z²+2)/24
//          + γ₁³(12z⁴−53z²+17)/324,          K = ⌊μ + σx + ½⌋,
//    whose CDF differs from the exact Poisson CDF by under kPoissonApproxMaxCdfError at every k
//    (tests/poisson_test.cpp computes the distance on a grid of means), with z a float
//    Box-Muller normal from 24-bit uniforms, so |z| <= 5.9 (no draw beyond ~5.9σ);
//  * normal: ⌊μ + √μ z + ½⌋, the plain rounded normal (an approximation, for comparison).
#pragma once
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>

#include "photosite/rng.h"
#include "photosite/sensor/poisson.h"

namespace photosite::detail {

// 1/k for the inversion loop (no division in the hot path).
extern const float kInverseInteger[64];

// e^x for x in [-87, 0]: n = round(x / ln2), r = x − n·ln2 with a two-part ln2 (Cody & Waite
// 1980) so r is accurate to an ulp, e^r by its Taylor series to r⁸ (|r| <= ln2/2: truncation
// < 1e-9), times 2^n built in the exponent bits. Relative error ~2 ulp.
inline float fast_exp(float x) {
  const float n = std::floor(x * 1.44269504f + 0.5f);
  const float r = (x - n * 0.693145752f) - n * 1.42860677e-6f;
  const float p = 1.0f + r * (1.0f + r * (0.5f + r * (1.66666667e-1f + r * (4.16666667e-2f +
                  r * (8.33333333e-3f + r * (1.38888889e-3f + r * (1.98412698e-4f + r * 2.48015873e-5f)))))));
  return p * std::bit_cast<float>(static_cast<uint32_t>(static_cast<int32_t>(n) + 127) << 23);
}

// The inversion uniform: 24 bits of word w, (w>>8 + ½)/2^24, open on both ends.
inline float inversion_uniform(uint32_t w) {
  return (static_cast<float>(static_cast<int32_t>(w >> 8)) + 0.5f) * 0x1p-24f;
}

// Poisson by inversion: K = #{k >= 0 : F(k) < u}. In float: the CDF carries ~1e-7 rounding,
// as fine as the 2^-24 grid of u. A step to k is taken only while P(K = k) > 1e-10, so a CDF
// that rounds to just under 1 cannot run away (the mass cut off is below 1e-10; for mean < 10
// nothing beyond k = 63 has mass above 1e-30 anyway).
inline constexpr float kInversionMinPmf = 1e-10f;
inline float poisson_inversion(float mean, uint32_t w) {
  const float u = inversion_uniform(w);
  float p = fast_exp(-mean), cdf = p, k = 0.f;
  for (int j = 1; j < 64; ++j) {
    p *= mean * kInverseInteger[j];
    const bool go = u > cdf && p > kInversionMinPmf;
    if (!go) break;
    k += 1.f;
    cdf += p;
  }
  return k;
}

// The corrected-normal quantile x(z) of the header comment, as a float polynomial in z (the
// same operations in the vectorized block loop and here, so both give the same bits).
struct CornishFisher {
  float mean, sigma, c0, c1, c2, c3, c4;  // x = c0 + c1 z + c2 z² + c3 z³ + c4 z⁴
  // Coefficients in float: they are O(1/√μ) corrections, float's 1e-7 is ample; float keeps
  // the block loop 8 lanes wide.
  explicit CornishFisher(float mu) {
    const float k2 = mu - 1.0f / 12.0f, s = std::sqrt(k2), inv_s = 1.0f / s, inv_k2 = inv_s * inv_s;
    const float g1 = mu * inv_k2 * inv_s, g2 = (mu + 1.0f / 120.0f) * inv_k2 * inv_k2,
                g3 = mu * inv_k2 * inv_k2 * inv_s;
    const float a = g1 * (1.0f / 6), b = g2 * (1.0f / 24), c = g1 * g1 * (1.0f / 36),
                d = g3 * (1.0f / 120), e = g1 * g2 * (1.0f / 24), f = g1 * g1 * g1 * (1.0f / 324);
    mean = mu;
    sigma = s;
    c0 = -a + 3 * d - 2 * e + 17 * f;
    c1 = 1 - 3 * b + 5 * c;
    c2 = a - 6 * d + 5 * e - 53 * f;
    c3 = b - 2 * c;
    c4 = d - e + 12 * f;
  }
  // The quantile in double (for tests): μ + σ x(z).
  double quantile(double z) const {
    return mean + static_cast<double>(sigma) * (c0 + z * (c1 + z * (c2 + z * (c3 + z * c4))));
  }
  double sample(float z) const {
    const float x = c0 + z * (c1 + z * (c2 + z * (c3 + z * c4)));
    return std::max(0.0, std::floor(static_cast<double>(mean) + static_cast<double>(sigma) * x + 0.5));
  }
};

// Box-Muller in float with polynomial log and cos: the vectorizable standard normal used by the
// sensor's hot loop (relative error of log and cos below 1e-6; IEEE sqrt).
// log(x) = e·ln2 + log(m), m in [√½, √2): log(m) = 2 atanh(t), t = (m−1)/(m+1), odd series to t⁹.
inline float fast_log(float x) {  // x > 0, finite
  const uint32_t bits = std::bit_cast<uint32_t>(x);
  int e = static_cast<int>((bits >> 23) & 0xff) - 127;
  float m = std::bit_cast<float>((bits & 0x007fffffu) | 0x3f800000u);  // [1, 2)
  const bool big = m > 1.41421356f;
  m = big ? m * 0.5f : m;
  e = big ? e + 1 : e;
  const float t = (m - 1.0f) / (m + 1.0f), t2 = t * t;
  const float s = t * (2.0f + t2 * (0.666666667f + t2 * (0.4f + t2 * (0.285714286f + t2 * 0.222222222f))));
  return static_cast<float>(e) * 0.693147181f + s;
}
// cos(2πv) for v in [0, 1): fold to |u| <= 1/4 around the nearest multiple of 1/2, Taylor to x¹².
inline float fast_cos_2pi(float v) {
  float u = std::fabs(v - std::floor(v + 0.5f));  // [0, 0.5]; cos is even
  const bool flip = u > 0.25f;
  u = flip ? 0.5f - u : u;  // cos(2π(½−u)) = −cos(2πu)
  const float x = 6.28318531f * u, x2 = x * x;
  const float c = 1.0f + x2 * (-0.5f + x2 * (4.16666667e-2f + x2 * (-1.38888889e-3f +
                  x2 * (2.48015873e-5f + x2 * (-2.75573192e-7f + x2 * 2.08767570e-9f)))));
  return flip ? -c : c;
}
inline float normal_from_words_f(uint32_t a, uint32_t b) {
  const float u = (static_cast<float>(static_cast<int32_t>(a >> 8)) + 0.5f) * 0x1p-24f;
  const float v = static_cast<float>(static_cast<int32_t>(b >> 8)) * 0x1p-24f;
  return std::sqrt(-2.0f * fast_log(u)) * fast_cos_2pi(v);
}

// PTRS (kernels/common/ptrs.glsl) compiled as C++: the prelude maps the GLSL subset that file
// uses onto C++ (the library is built with -ffp-contract=off, so `precise` has nothing to add).
namespace shader_subset {
using uint = uint32_t;
using std::abs;
using std::floor;
using std::max;
using std::min;
using std::sqrt;
#define precise
#define PS_FN inline
#include "../../../kernels/common/ptrs.glsl"
#undef PS_FN
#undef precise
}  // namespace shader_subset
using shader_subset::kPtrsMaxRetryCalls;
using shader_subset::kPtrsRetryStreamStep;
using shader_subset::ptrs_accept;
using shader_subset::ptrs_attempt;
using shader_subset::ptrs_candidate;
using shader_subset::ptrs_log_pmf;
using shader_subset::ptrs_setup;
using shader_subset::PtrsCandidate;
using shader_subset::PtrsSetup;

// The stream word of PTRS retry call r (1-based), the same in poisson.glsl.
inline uint32_t ptrs_retry_stream(uint32_t stream, int r) {
  return stream + static_cast<uint32_t>(r) * kPtrsRetryStreamStep;
}

// One exact Poisson(μ) draw, μ >= 10, by PTRS on the pixel's words (w0, w1) and, when those are
// rejected, on retry words of the same (seed, frame, pixel) counter. Scalar reference of the
// vectorized loop in sensor/poisson.cpp and of poisson.glsl.
inline float ptrs_sample(float mu, uint32_t w0, uint32_t w1, uint64_t seed, uint32_t frame, uint64_t pixel,
                         uint32_t stream) {
  const PtrsSetup s = ptrs_setup(mu);
  float k = ptrs_attempt(s, w0, w1);
  for (int r = 1; k < 0 && r <= kPtrsMaxRetryCalls; ++r) {
    const auto w = random_words(seed, frame, pixel, static_cast<Stream>(ptrs_retry_stream(stream, r)));
    k = ptrs_attempt(s, w[0], w[1]);
    if (k < 0) k = ptrs_attempt(s, w[2], w[3]);
  }
  return k < 0 ? s.mu_int : k;
}

}  // namespace photosite::detail
