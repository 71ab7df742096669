// The per-pixel Poisson draws, written once in the C++/GLSL common subset (common/prelude.glsl)
// for the C++ library (sensor/poisson_detail.h, whose header comment has the maths) and the
// kernels (common/poisson.glsl): inversion below mean 10, PTRS (common/ptrs.glsl) with its
// retries, the Sheppard-corrected Cornish-Fisher quantile (an approximation) and the rounded
// normal (an approximation). The includer provides kInverseInteger[64] (1/k in float; the GLSL
// table is common/inverse_integer.glsl, the C++ one sensor/poisson.cpp) and includes
// fastmath.glsl, philox_round.glsl and ptrs.glsl first.
#ifndef PHOTOSITE_POISSON_DRAWS_GLSL
#define PHOTOSITE_POISSON_DRAWS_GLSL

// Poisson by inversion: K = #{k >= 0 : F(k) < u}. In float: the CDF carries ~1e-7 rounding,
// as fine as the 2^-24 grid of u. A step to k is taken only while P(K = k) > 1e-10, so a CDF
// that rounds to just under 1 cannot run away (the mass cut off is below 1e-10; for mean < 10
// nothing beyond k = 63 has mass above 1e-30 anyway).
const float kInversionMinPmf = 1e-10f;
PS_FN float poisson_inversion(float mean, uint w) {
  const float u = inversion_uniform(w);
  precise float p = fast_exp(-mean);
  precise float cdf = p;
  precise float k = 0.0f;
  for (int j = 1; j < 64; ++j) {
    p *= mean * kInverseInteger[j];
    const bool go = u > cdf && p > kInversionMinPmf;
    if (!go) break;
    k += 1.0f;
    cdf += p;
  }
  return k;
}

// The corrected-normal quantile x(z) = c0 + c1 z + c2 z² + c3 z³ + c4 z⁴ of the Cornish-Fisher
// expansion (coefficients in float: they are O(1/√μ) corrections, float's 1e-7 is ample).
struct CornishFisherCoeffs {
  float mean, sigma, c0, c1, c2, c3, c4;
};
PS_FN CornishFisherCoeffs cornish_fisher_setup(float mu) {
  precise float k2 = mu - 1.0f / 12.0f;
  precise float s = sqrt_rn(k2);
  precise float inv_s = div_rn(1.0f, s);
  precise float inv_k2 = inv_s * inv_s;
  precise float g1 = mu * inv_k2 * inv_s;
  precise float g2 = (mu + 1.0f / 120.0f) * inv_k2 * inv_k2;
  precise float g3 = mu * inv_k2 * inv_k2 * inv_s;
  precise float a = g1 * (1.0f / 6.0f), b = g2 * (1.0f / 24.0f), c = g1 * g1 * (1.0f / 36.0f),
                d = g3 * (1.0f / 120.0f), e = g1 * g2 * (1.0f / 24.0f), f = g1 * g1 * g1 * (1.0f / 324.0f);
  // Through precise locals: `precise` does not reach an assignment to a struct member, and a driver
  // could fuse 3·d + … into a fused multiply-add, which C++ (-ffp-contract=off) never does.
  precise float c0 = -a + 3.0f * d - 2.0f * e + 17.0f * f;
  precise float c1 = 1.0f - 3.0f * b + 5.0f * c;
  precise float c2 = a - 6.0f * d + 5.0f * e - 53.0f * f;
  precise float c3 = b - 2.0f * c;
  precise float c4 = d - e + 12.0f * f;
  CornishFisherCoeffs cf;
  cf.mean = mu;
  cf.sigma = s;
  cf.c0 = c0;
  cf.c1 = c1;
  cf.c2 = c2;
  cf.c3 = c3;
  cf.c4 = c4;
  return cf;
}
// K = max(0, ⌊μ + σx(z) + ½⌋), the last sum in double (σ·x of two floats is exact in double).
PS_FN float cornish_fisher_sample(CornishFisherCoeffs cf, float z) {
  precise float x = cf.c0 + z * (cf.c1 + z * (cf.c2 + z * (cf.c3 + z * cf.c4)));
  precise double k = floor(double(cf.mean) + double(cf.sigma) * double(x) + double(0.5f));
  return float(max(double(0.0f), k));
}

// The plain rounded normal ⌊μ + √μ z + ½⌋ (negative, zero or NaN means: 0).
PS_FN float rounded_normal_sample(float mean, float z) {
  precise float mu = max(mean, 0.0f);
  precise float k = floor(mu + sqrt_rn(mu) * z + 0.5f);
  return max(0.0f, k);
}

// The stream word of PTRS retry call r (1-based).
PS_FN uint ptrs_retry_stream(uint stream, int r) { return stream + uint(r) * kPtrsRetryStreamStep; }

// One exact Poisson(μ) draw, μ >= 10, by PTRS on the pixel's words (w0, w1) and, when those are
// rejected, on retry words of the same (key, frame, pixel) counter, two attempts per call.
// The scalar reference of the vectorized block loop in sensor/poisson.cpp.
PS_FN float ptrs_sample(float mu, uint w0, uint w1, uvec2 key, uint frame, uvec2 pixel, uint stream) {
  const PtrsSetup s = ptrs_setup(mu);
  float k = ptrs_attempt(s, w0, w1);
  for (int r = 1; k < 0.0f && r <= kPtrsMaxRetryCalls; ++r) {
    const uvec4 rw = random_words(key, frame, pixel, ptrs_retry_stream(stream, r));
    k = ptrs_attempt(s, rw.x, rw.y);
    if (k < 0.0f) k = ptrs_attempt(s, rw.z, rw.w);
  }
  return k < 0.0f ? s.mu_int : k;
}

#endif
