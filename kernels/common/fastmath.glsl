// e^x, log x and cos 2πv in float by polynomials, and the float Box-Muller normal built on them:
// the vectorizable functions of the sensor's hot loop, written once in the C++/GLSL common
// subset (common/prelude.glsl) for the C++ library (sensor/poisson_detail.h) and the kernels
// (common/poisson.glsl). Every operation is `precise` (GLSL) or uncontracted (C++,
// -ffp-contract=off), so both give the same bits. These are APPROXIMATIONS of the functions,
// with the errors stated below (tests/poisson_test.cpp checks them against libm).
#ifndef PHOTOSITE_FASTMATH_GLSL
#define PHOTOSITE_FASTMATH_GLSL

const float kTwoPowMinus24 = 5.9604644775390625e-8f;  // 2^-24, exact

// e^x for x in [-87, 0]: n = round(x / ln2), r = x − n·ln2 with a two-part ln2 (Cody & Waite
// 1980) so r is accurate to an ulp, e^r by its Taylor series to r⁸ (|r| <= ln2/2: truncation
// < 1e-9), times 2^n built in the exponent bits. Relative error ~2 ulp.
PS_FN float fast_exp(float x) {
  precise float n = floor(x * 1.44269504f + 0.5f);
  precise float r = (x - n * 0.693145752f) - n * 1.42860677e-6f;
  precise float p = 1.0f + r * (1.0f + r * (0.5f + r * (1.66666667e-1f + r * (4.16666667e-2f +
                    r * (8.33333333e-3f + r * (1.38888889e-3f + r * (1.98412698e-4f + r * 2.48015873e-5f)))))));
  precise float result = p * uintBitsToFloat(uint(int(n) + 127) << 23);
  return result;
}

// The inversion uniform: 24 bits of word w, (w>>8 + ½)/2^24, open on both ends.
PS_FN float inversion_uniform(uint w) {
  precise float u = (float(int(w >> 8)) + 0.5f) * kTwoPowMinus24;
  return u;
}

// log(x), x > 0 finite: log x = e·ln2 + log(m), m in [√½, √2): log(m) = 2 atanh(t),
// t = (m−1)/(m+1), odd series to t⁹. Relative error below 1e-6.
PS_FN float fast_log(float x) {
  const uint bits = floatBitsToUint(x);
  int e = int((bits >> 23) & 0xffu) - 127;
  precise float m = uintBitsToFloat((bits & 0x007fffffu) | 0x3f800000u);  // [1, 2)
  const bool big = m > 1.41421356f;
  m = big ? m * 0.5f : m;
  e = big ? e + 1 : e;
  precise float t = div_rn(m - 1.0f, m + 1.0f);
  precise float t2 = t * t;
  precise float s = t * (2.0f + t2 * (0.666666667f + t2 * (0.4f + t2 * (0.285714286f + t2 * 0.222222222f))));
  precise float result = float(e) * 0.693147181f + s;
  return result;
}

// cos(2πv) for v in [0, 1): fold to |u| <= 1/4 around the nearest multiple of 1/2, Taylor to x¹².
// Absolute error below 1e-6.
PS_FN float fast_cos_2pi(float v) {
  precise float u = abs(v - floor(v + 0.5f));  // [0, 0.5]; cos is even
  const bool flip = u > 0.25f;
  // cos(2π(½−u)) = −cos(2πu): fold to min(u, ½ − u), the same float as flip ? ½ − u : u (when
  // flip, u is in (¼, ½] and ½ − u is exact (Sterbenz) and below u; else ½ − u rounds to >= ¼
  // >= u). A min rather than a select on flip, which GCC's vectorizer split into two
  // polynomials, one per side, selected after (16 more vector instructions per 16 normals).
  precise float folded = min(u, 0.5f - u);
  precise float x = 6.28318531f * folded;
  precise float x2 = x * x;
  precise float c = 1.0f + x2 * (-0.5f + x2 * (4.16666667e-2f + x2 * (-1.38888889e-3f +
                    x2 * (2.48015873e-5f + x2 * (-2.75573192e-7f + x2 * 2.08767570e-9f)))));
  return flip ? -c : c;
}

// A standard normal from two words by Box-Muller in float (IEEE sqrt): u from 24 bits of a,
// open on both ends, v from 24 bits of b, so |z| <= 5.9.
PS_FN float normal_from_words_f(uint a, uint b) {
  precise float u = (float(int(a >> 8)) + 0.5f) * kTwoPowMinus24;
  precise float v = float(int(b >> 8)) * kTwoPowMinus24;
  precise float z = sqrt_rn(-2.0f * fast_log(u)) * fast_cos_2pi(v);
  return z;
}

#endif
