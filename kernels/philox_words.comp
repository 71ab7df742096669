// The four Philox words of pixels first_pixel + i (for the parity test of common/philox.glsl
// against include/photosite/rng.h).
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/philox.glsl"
layout(local_size_x = 256) in;

// gpu::PoissonParams (the same fields; `method` unused)
#include "common/params_poisson.glsl"
layout(std430, binding = 0) writeonly buffer Out { uvec4 words[]; };

void main() {
  const uint i = linear_invocation();
  if (i >= P.n) return;
  words[i] = random_words(P.key, P.frame, pixel_index(P.first_pixel, i), P.stream);
}
