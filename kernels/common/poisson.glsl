// The per-pixel Poisson draw of the kernels. The maths is written once, in files of the
// C++/GLSL common subset that the C++ library compiles as well (sensor/poisson_detail.h has the
// header comment with the maths): fastmath.glsl (fast_exp, fast_log, fast_cos_2pi, the float
// Box-Muller normal), ptrs.glsl (PTRS) and poisson_draws.glsl (inversion, PTRS with retries,
// Cornish-Fisher, rounded normal). What is left here is the kernels' dispatch on the method,
// which the C++ path does block-wise in sensor/poisson.cpp. `precise` forbids the compiler to
// fuse or reorder float operations, so the kernels give the CPU path's bits (the CPU side is
// compiled with -ffp-contract=off for the same reason).
#ifndef PHOTOSITE_POISSON_GLSL
#define PHOTOSITE_POISSON_GLSL
#extension GL_GOOGLE_include_directive : enable
#include "common/prelude.glsl"
#include "common/inverse_integer.glsl"
#include "common/philox.glsl"
#include "common/fastmath.glsl"
#include "common/ptrs.glsl"
#include "common/poisson_draws.glsl"

const float kPoissonApproxThreshold = 10.0;

// PoissonMethod as the kernels receive it (the enum's order).
const uint kPoissonExact = 0u, kPoissonCornishFisher = 1u, kPoissonNormal = 2u;

// One Poisson(mean) draw for the pixel whose Philox words are w (w.x, w.y drive it; PTRS
// retries draw more from (key, frame, pixel) on retry streams): poisson_block's draw for
// `method`. Zero, negative or NaN means give 0.
float poisson_from_words(float mean, uvec4 w, uvec2 key, uint frame, uvec2 pixel, uint stream, uint method) {
  if (method == kPoissonNormal) return rounded_normal_sample(mean, normal_from_words_f(w.x, w.y));
  if (mean >= kPoissonApproxThreshold)
    return method == kPoissonExact ? ptrs_sample(mean, w.x, w.y, key, frame, pixel, stream)
                                   : cornish_fisher_sample(cornish_fisher_setup(mean), normal_from_words_f(w.x, w.y));
  if (mean > 0.0) return poisson_inversion(mean, w.x);
  return 0.0;
}

#endif
