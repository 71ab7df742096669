// The per-pixel Poisson samplers of include/photosite/sensor/poisson_detail.h, operation for
// operation (the header comment there has the maths: inversion below mean 10; above, PTRS
// (common/ptrs.glsl, the same source the C++ compiles) or the Sheppard-corrected
// Cornish-Fisher quantile; or the rounded normal everywhere). `precise` forbids the compiler to fuse or
// reorder these float operations, so the kernels give the CPU path's bits (the CPU side is
// compiled with -ffp-contract=off for the same reason).
#ifndef PHOTOSITE_POISSON_GLSL
#define PHOTOSITE_POISSON_GLSL
#extension GL_GOOGLE_include_directive : enable
#include "common/inverse_integer.glsl"
#include "common/philox.glsl"

const float kPoissonApproxThreshold = 10.0;
const float kInversionMinPmf = 1e-10;
const float kTwoPowMinus24 = 5.9604644775390625e-8;  // 2^-24

// e^x for x in [-87, 0] (Cody-Waite reduction, Taylor to r^8): detail::fast_exp.
float fast_exp(float x) {
  precise float n = floor(x * 1.44269504 + 0.5);
  precise float r = (x - n * 0.693145752) - n * 1.42860677e-6;
  precise float p = 1.0 + r * (1.0 + r * (0.5 + r * (1.66666667e-1 + r * (4.16666667e-2 +
                    r * (8.33333333e-3 + r * (1.38888889e-3 + r * (1.98412698e-4 + r * 2.48015873e-5)))))));
  precise float result = p * uintBitsToFloat(uint(int(n) + 127) << 23);
  return result;
}

float inversion_uniform(uint w) {
  precise float u = (float(int(w >> 8)) + 0.5) * kTwoPowMinus24;
  return u;
}

// K = #{k >= 0 : F(k) < u}: detail::poisson_inversion.
float poisson_inversion(float mean, uint w) {
  const float u = inversion_uniform(w);
  precise float p = fast_exp(-mean);
  precise float cdf = p;
  float k = 0.0;
  for (int j = 1; j < 64; ++j) {
    p *= mean * kInverseInteger[j];
    if (!(u > cdf && p > kInversionMinPmf)) break;
    k += 1.0;
    cdf += p;
  }
  return k;
}

// log, cos(2πv) and Box-Muller in float: detail::fast_log, fast_cos_2pi, normal_from_words_f.
float fast_log(float x) {
  const uint bits = floatBitsToUint(x);
  int e = int((bits >> 23) & 0xffu) - 127;
  precise float m = uintBitsToFloat((bits & 0x007fffffu) | 0x3f800000u);
  const bool big = m > 1.41421356;
  m = big ? m * 0.5 : m;
  e = big ? e + 1 : e;
  precise float t = (m - 1.0) / (m + 1.0);
  precise float t2 = t * t;
  precise float s = t * (2.0 + t2 * (0.666666667 + t2 * (0.4 + t2 * (0.285714286 + t2 * 0.222222222))));
  precise float result = float(e) * 0.693147181 + s;
  return result;
}
float fast_cos_2pi(float v) {
  precise float u = abs(v - floor(v + 0.5));
  const bool flip = u > 0.25;
  u = flip ? 0.5 - u : u;
  precise float x = 6.28318531 * u;
  precise float x2 = x * x;
  precise float c = 1.0 + x2 * (-0.5 + x2 * (4.16666667e-2 + x2 * (-1.38888889e-3 +
                    x2 * (2.48015873e-5 + x2 * (-2.75573192e-7 + x2 * 2.08767570e-9)))));
  return flip ? -c : c;
}
float normal_from_words_f(uint a, uint b) {
  precise float u = (float(int(a >> 8)) + 0.5) * kTwoPowMinus24;
  precise float v = float(int(b >> 8)) * kTwoPowMinus24;
  precise float z = sqrt(-2.0 * fast_log(u)) * fast_cos_2pi(v);
  return z;
}

// detail::CornishFisher(mu).sample(z): x = c0 + c1 z + c2 z² + c3 z³ + c4 z⁴, K = ⌊μ + σx + ½⌋
// (the last sum in double, as on the CPU; σ·x of two floats is exact in double).
float corrected_normal(float mu, float z) {
  precise float k2 = mu - 1.0 / 12.0;
  precise float s = sqrt(k2);
  precise float inv_s = 1.0 / s;
  precise float inv_k2 = inv_s * inv_s;
  precise float g1 = mu * inv_k2 * inv_s;
  precise float g2 = (mu + 1.0 / 120.0) * inv_k2 * inv_k2;
  precise float g3 = mu * inv_k2 * inv_k2 * inv_s;
  precise float a = g1 * (1.0 / 6.0), b = g2 * (1.0 / 24.0), c = g1 * g1 * (1.0 / 36.0),
                d = g3 * (1.0 / 120.0), e = g1 * g2 * (1.0 / 24.0), f = g1 * g1 * g1 * (1.0 / 324.0);
  precise float c0 = -a + 3.0 * d - 2.0 * e + 17.0 * f;
  precise float c1 = 1.0 - 3.0 * b + 5.0 * c;
  precise float c2 = a - 6.0 * d + 5.0 * e - 53.0 * f;
  precise float c3 = b - 2.0 * c;
  precise float c4 = d - e + 12.0 * f;
  precise float x = c0 + z * (c1 + z * (c2 + z * (c3 + z * c4)));
  precise double k = floor(double(mu) + double(s) * double(x) + 0.5lf);
  return float(max(0.0lf, k));
}

// PTRS, common/ptrs.glsl, with the GLSL side of its prelude.
#define PS_FN
#include "common/ptrs.glsl"

// detail::ptrs_sample: the pixel's words (w.x, w.y) first, then two attempts per retry call.
float ptrs_sample(float mu, uvec4 w, uvec2 key, uint frame, uvec2 pixel, uint stream) {
  const PtrsSetup s = ptrs_setup(mu);
  float k = ptrs_attempt(s, w.x, w.y);
  for (int r = 1; k < 0.0 && r <= kPtrsMaxRetryCalls; ++r) {
    const uvec4 rw = random_words(key, frame, pixel, stream + uint(r) * kPtrsRetryStreamStep);
    k = ptrs_attempt(s, rw.x, rw.y);
    if (k < 0.0) k = ptrs_attempt(s, rw.z, rw.w);
  }
  return k < 0.0 ? s.mu_int : k;
}

// PoissonMethod as the kernels receive it (the enum's order).
const uint kPoissonExact = 0u, kPoissonCornishFisher = 1u, kPoissonNormal = 2u;

// One Poisson(mean) draw for the pixel whose Philox words are w (w.x, w.y drive it; PTRS
// retries draw more from (key, frame, pixel) on retry streams): poisson_block's draw for
// `method`. Zero, negative or NaN means give 0.
float poisson_from_words(float mean, uvec4 w, uvec2 key, uint frame, uvec2 pixel, uint stream, uint method) {
  if (method == kPoissonNormal) {
    precise float mu = max(mean, 0.0);
    precise float k = floor(mu + sqrt(mu) * normal_from_words_f(w.x, w.y) + 0.5);
    return max(0.0, k);
  }
  if (mean >= kPoissonApproxThreshold)
    return method == kPoissonExact ? ptrs_sample(mean, w, key, frame, pixel, stream)
                                   : corrected_normal(mean, normal_from_words_f(w.x, w.y));
  if (mean > 0.0) return poisson_inversion(mean, w.x);
  return 0.0;
}

#endif
