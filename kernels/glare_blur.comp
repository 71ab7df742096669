// The lens-glare pyramid's Gaussian along rows (sensor/glare.cpp blur_rows): σ = 1 level
// pixel, taps centre first from the host (glare_blur_taps), mirror borders, summed from −3 to 3.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/philox.glsl"
#include "common/glare.glsl"
layout(local_size_x = 256) in;

// gpu::GlareParams (gpu/kernels.h)
#include "common/params_glare.glsl"
layout(std430, binding = 0) readonly buffer Src { float src[]; };
layout(std430, binding = 1) writeonly buffer Dst { float dst[]; };

void main() {
  const uint i = linear_invocation();
  if (i >= uint(P.src_w * P.src_h)) return;
  const int x = int(i % uint(P.src_w)), y = int(i / uint(P.src_w));
  precise float a0 = 0.0, a1 = 0.0, a2 = 0.0;
  for (int k = -3; k <= 3; ++k) {
    const float wk = P.taps[abs(k)];
    const int s = 3 * (y * P.src_w + glare_mirror(x + k, P.src_w));
    a0 = a0 + wk * src[s];
    a1 = a1 + wk * src[s + 1];
    a2 = a2 + wk * src[s + 2];
  }
  dst[3 * i] = a0;
  dst[3 * i + 1] = a1;
  dst[3 * i + 2] = a2;
}
