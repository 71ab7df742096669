// One octave down the lens-glare pyramid (sensor/glare.cpp down2 / down_1331), float
// operation for operation: mode 0 the 2x2 box average of level 1 (edge clamped); mode 1 the
// (1,3,3,1)/8 filter along rows with decimation (src w x h → dst ceil(w/2) x h); mode 2 along
// columns (src w x h → dst w x ceil(h/2)), mirror borders.
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
  if (i >= uint(P.dst_w * P.dst_h)) return;
  const int x = int(i % uint(P.dst_w)), y = int(i / uint(P.dst_w));
  for (int c = 0; c < 3; ++c) {
    precise float v;
    if (P.mode == 0) {
      const int xa = 2 * x, xb = min(2 * x + 1, P.src_w - 1);
      const int ya = 2 * y, yb = min(2 * y + 1, P.src_h - 1);
      const float a = src[3 * (ya * P.src_w + xa) + c], b = src[3 * (ya * P.src_w + xb) + c];
      const float d0 = src[3 * (yb * P.src_w + xa) + c], d1 = src[3 * (yb * P.src_w + xb) + c];
      v = ((a + b) + (d0 + d1)) * 0.25;
    } else if (P.mode == 1) {
      const int r = y * P.src_w;
      const float a = src[3 * (r + glare_mirror(2 * x - 1, P.src_w)) + c];
      const float b = src[3 * (r + glare_mirror(2 * x, P.src_w)) + c];
      const float d0 = src[3 * (r + glare_mirror(2 * x + 1, P.src_w)) + c];
      const float d1 = src[3 * (r + glare_mirror(2 * x + 2, P.src_w)) + c];
      v = (0.125 * a + 0.375 * b) + (0.375 * d0 + 0.125 * d1);
    } else {
      const float a = src[3 * (glare_mirror(2 * y - 1, P.src_h) * P.src_w + x) + c];
      const float b = src[3 * (glare_mirror(2 * y, P.src_h) * P.src_w + x) + c];
      const float d0 = src[3 * (glare_mirror(2 * y + 1, P.src_h) * P.src_w + x) + c];
      const float d1 = src[3 * (glare_mirror(2 * y + 2, P.src_h) * P.src_w + x) + c];
      v = (0.125 * a + 0.375 * b) + (0.375 * d0 + 0.125 * d1);
    }
    dst[3 * i + c] = v;
  }
}
