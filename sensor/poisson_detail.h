// The per-pixel Poisson samplers, shared by the sensor loop, the benchmark and the tests.
// PoissonMethod (poisson.h) picks one of three:
//  * exact: below mean kPoissonApproxThreshold (10) inversion by sequential search on a 24-bit
//    uniform (exact up to the 2^-24 grid of the uniform); from 10 up Hörmann's PTRS, an exact
//    rejection sampler (kernels/common/ptrs.glsl has its maths);
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
// The functions are written once, in the C++/GLSL common subset (kernels/common/prelude.glsl):
// kernels/common/fastmath.glsl (fast_exp, fast_log, fast_cos_2pi, the float Box-Muller normal),
// ptrs.glsl (PTRS) and poisson_draws.glsl (inversion, PTRS with retries, Cornish-Fisher, the
// rounded normal). This private header (not installed) compiles them as C++ in namespace
// photosite::shader; the Vulkan kernels compile the same files (kernels/common/poisson.glsl).
#pragma once
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>

#include "core/rng_detail.h"
#include "photosite/rng.h"
#include "photosite/sensor/poisson.h"

namespace photosite::shader {
extern const float kInverseInteger[64];  // 1/k in float, k = 0..63 (sensor/poisson.cpp)
#include "common/prelude.glsl"
#include "common/fastmath.glsl"
#include "common/ptrs.glsl"
#include "common/poisson_draws.glsl"
#include "common/prelude_end.glsl"
}  // namespace photosite::shader

namespace photosite::detail {

using shader::cornish_fisher_sample;
using shader::cornish_fisher_setup;
using shader::CornishFisherCoeffs;
using shader::fast_cos_2pi;
using shader::fast_exp;
using shader::fast_log;
using shader::inversion_uniform;
using shader::kInverseInteger;
using shader::kInversionMinPmf;
using shader::kPtrsMaxRetryCalls;
using shader::kPtrsRetryStreamStep;
using shader::normal_from_words_f;
using shader::poisson_inversion;
using shader::ptrs_accept;
using shader::ptrs_attempt;
using shader::ptrs_candidate;
using shader::ptrs_log_pmf;
using shader::ptrs_retry_stream;
using shader::ptrs_setup;
using shader::PtrsCandidate;
using shader::PtrsSetup;
using shader::rounded_normal_sample;

// The Cornish-Fisher quantile of the header comment (cornish_fisher_setup/_sample), with the
// quantile in double for the tests.
struct CornishFisher : CornishFisherCoeffs {
  explicit CornishFisher(float mu) : CornishFisherCoeffs(cornish_fisher_setup(mu)) {}
  // μ + σ x(z) in double.
  double quantile(double z) const {
    return mean + static_cast<double>(sigma) * (c0 + z * (c1 + z * (c2 + z * (c3 + z * c4))));
  }
  float sample(float z) const { return cornish_fisher_sample(*this, z); }
};

// One exact Poisson(μ) draw, μ >= 10 (shader::ptrs_sample with 64-bit seed and pixel): the scalar
// reference of the vectorized loop in sensor/poisson.cpp and of the kernels.
inline float ptrs_sample(float mu, uint32_t w0, uint32_t w1, uint64_t seed, uint32_t frame, uint64_t pixel,
                         uint32_t stream) {
  return shader::ptrs_sample(mu, w0, w1, halves(seed), frame, halves(pixel), stream);
}

// The block Philox4x32-10 words (poisson_block's generator) come from the widest of three paths
// the CPU has: scalar (shader::random_words per pixel), AVX2 (8 pixels a vector) or AVX-512
// (16). Integer operations only, so every path gives the same words (test
// Philox.BlockWordsEqualScalarOnEveryPath). set_philox_path narrows the path the sampler uses
// (to at most the best the CPU has; for tests and the generator benchmark) and returns the one
// before; philox_block_words runs one path directly.
enum class PhiloxPath { Scalar = 0, Avx2 = 1, Avx512 = 2 };
PhiloxPath best_philox_path();
PhiloxPath set_philox_path(PhiloxPath path);
void philox_block_words(PhiloxPath path, uint64_t key, uint32_t frame, uint64_t first_pixel, uint32_t stream, int n,
                        uint32_t* w0, uint32_t* w1, uint32_t* w2, uint32_t* w3);

// Benchmark only (bench sense): the block generator on the AVX2 or AVX-512 path with `rounds` =
// 10 (Philox4x32-10, the generator of every result) or 7 (Philox4x32-7, not used for any
// result), to time what the three extra rounds cost.
void philox_words_rounds(int rounds, PhiloxPath path, uint64_t key, uint32_t frame, uint64_t first_pixel,
                         uint32_t stream, int n, uint32_t* w0, uint32_t* w1, uint32_t* w2, uint32_t* w3);

// One PTRS attempt (ptrs_attempt) per lane i < m (m a multiple of 8, at most 1024; mu[i] >= 10)
// from the words wu[i], wv[i]: k[i] >= 0 accepted, −1 rejected; the sampler's retries.
// squeeze_first: its path (candidates and squeeze on every lane, the full test only on the
// undecided lanes, compacted); otherwise the definition (the full test on every lane).
void ptrs_attempt_lanes(bool squeeze_first, const float* mu, const uint32_t* wu, const uint32_t* wv, float* k, int m);

// The sampler's lane packing (sensor/poisson.cpp, pack_lanes, on the current Philox path), for the
// tests: the lanes i < m where keep[i] != 0, in order, their indices into idx and their values
// src[i] into dst; returns their count. idx and dst hold m + kPackLanesRoom lanes (whole vectors
// are stored past the count).
constexpr int kPackLanesRoom = 16;
int pack_lanes_for_test(const float* keep, int m, int* idx, const float* src, float* dst);

}  // namespace photosite::detail
