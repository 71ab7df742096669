// One level of the lens-glare pyramid's collapse (sensor/glare.cpp blur_cols_add):
//   acc_l = w·blur_columns(t) + up(acc_{l+1}),
// t the row-blurred level (flags bit 0; absent on the levels finer than lo: acc_l = up(acc_{l+1})),
// acc_{l+1} the coarser accumulator (flags bit 1; absent on the coarsest level). Bilinear
// upsampling interpolates the coarse rows first, then the columns, as the CPU.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/philox.glsl"
#include "common/glare.glsl"
layout(local_size_x = 256) in;

// gpu::GlareParams (gpu/kernels.h): dst_w x dst_h this level, src_w x src_h the coarse one
layout(push_constant, std430) uniform Params {
  int src_w, src_h, dst_w, dst_h;
  int mode, flags;
  float weight;
  float taps[4];
  uint pad;
  double eta;
} P;
layout(std430, binding = 0) readonly buffer T { float t[]; };
layout(std430, binding = 1) readonly buffer Coarse { float coarse[]; };
layout(std430, binding = 2) writeonly buffer Acc { float acc[]; };

void main() {
  const uint i = linear_invocation();
  if (i >= uint(P.dst_w * P.dst_h)) return;
  const int x = int(i % uint(P.dst_w)), y = int(i / uint(P.dst_w));
  const bool blur = (P.flags & 1) != 0, up = (P.flags & 2) != 0;
  precise float u[3] = float[3](0.0, 0.0, 0.0);
  if (up) {
    int r0, r1, c0, c1;
    float wy0, wy1, wx0, wx1;
    glare_up_tap(y, P.src_h, r0, r1, wy0, wy1);
    glare_up_tap(x, P.src_w, c0, c1, wx0, wx1);
    for (int c = 0; c < 3; ++c) {
      precise float t0 = wy0 * coarse[3 * (r0 * P.src_w + c0) + c] + wy1 * coarse[3 * (r1 * P.src_w + c0) + c];
      precise float t1 = wy0 * coarse[3 * (r0 * P.src_w + c1) + c] + wy1 * coarse[3 * (r1 * P.src_w + c1) + c];
      u[c] = wx0 * t0 + wx1 * t1;
    }
  }
  for (int c = 0; c < 3; ++c) {
    precise float v;
    if (!blur) {
      v = u[c];
    } else {
      precise float a = 0.0;
      for (int k = -3; k <= 3; ++k)
        a = a + P.taps[abs(k)] * t[3 * (glare_mirror(y + k, P.dst_h) * P.dst_w + x) + c];
      v = up ? P.weight * a + u[c] : P.weight * a;
    }
    acc[3 * i + c] = v;
  }
}
