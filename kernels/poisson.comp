// Poisson shot noise: out[i] ~ Poisson(mean[i]) for pixels first_pixel + i, the draw of
// photosite::poisson_fill bit for bit, for the PoissonMethod in the push constants.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/philox.glsl"
#include "common/poisson.glsl"
layout(local_size_x = 256) in;

// gpu::PoissonParams (gpu/kernels.h)
#include "common/params_poisson.glsl"
layout(std430, binding = 0) readonly buffer Mean { float mean[]; };
layout(std430, binding = 1) writeonly buffer Out { float result[]; };

void main() {
  const uint i = linear_invocation();
  if (i >= P.n) return;
  const uvec2 pixel = pixel_index(P.first_pixel, i);
  const uvec4 w = random_words(P.key, P.frame, pixel, P.stream);
  result[i] = poisson_from_words(mean[i], w, P.key, P.frame, pixel, P.stream, P.method);
}
