// exp() in double precision for GLSL, which has no double exp (GLSL 4.50 §8.2: exp takes
// genFType only). Cody-Waite range reduction x = k·ln2 + r, |r| <= ln2/2, with ln2 split in a
// high part whose products k·ln2_hi are exact (fdlibm e_exp.c's constants), then the Taylor
// series of e^r to degree 13 (truncation below 3e-18 relative) and a scale by 2^k. Error a few
// double ulps, so float(exp64(x)) equals the C++ path's static_cast<float>(std::exp(x)) except
// where the double lies within those ulps of a float rounding boundary (about 1e-8 of values).
// Domain: |x| < 700 (no overflow or subnormal handling; photosite calls it on [-8, 0]).
#ifndef PHOTOSITE_EXP64_GLSL
#define PHOTOSITE_EXP64_GLSL

double exp64(double x) {
  const double ln2_hi = 6.93147180369123816490e-01LF;
  const double ln2_lo = 1.90821492927058770002e-10LF;
  const double inv_ln2 = 1.44269504088896338700e+00LF;
  const double k = roundEven(x * inv_ln2);
  precise double r = (x - k * ln2_hi) - k * ln2_lo;
  // Horner from 1/13! down to 1.
  precise double p = 1.0LF / 6227020800.0LF;
  p = p * r + 1.0LF / 479001600.0LF;
  p = p * r + 1.0LF / 39916800.0LF;
  p = p * r + 1.0LF / 3628800.0LF;
  p = p * r + 1.0LF / 362880.0LF;
  p = p * r + 1.0LF / 40320.0LF;
  p = p * r + 1.0LF / 5040.0LF;
  p = p * r + 1.0LF / 720.0LF;
  p = p * r + 1.0LF / 120.0LF;
  p = p * r + 1.0LF / 24.0LF;
  p = p * r + 1.0LF / 6.0LF;
  p = p * r + 0.5LF;
  p = p * r + 1.0LF;
  p = p * r + 1.0LF;
  return ldexp(p, int(k));
}

#endif
