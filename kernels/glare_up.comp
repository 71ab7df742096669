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
#include "common/params_glare.glsl"
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
    const GlareTap ty = glare_up_tap(y, P.src_h), tx = glare_up_tap(x, P.src_w);
    for (int c = 0; c < 3; ++c) {
      const float t0 = glare_lerp(ty.w0, coarse[3 * (ty.i0 * P.src_w + tx.i0) + c], ty.w1,
                                  coarse[3 * (ty.i1 * P.src_w + tx.i0) + c]);
      const float t1 = glare_lerp(ty.w0, coarse[3 * (ty.i0 * P.src_w + tx.i1) + c], ty.w1,
                                  coarse[3 * (ty.i1 * P.src_w + tx.i1) + c]);
      u[c] = glare_lerp(tx.w0, t0, tx.w1, t1);
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
