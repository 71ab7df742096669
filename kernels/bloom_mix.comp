// The bloom's last step, as in bloom_in_place: the full-size image keeps (1 − f) of itself and
// gains f/levels times the bilinear upsample (pixel-centre aligned) of the collapsed chain:
//   o = keep·o + a + (b − a)·wx, a, b the vertically interpolated, spread-scaled coarse samples.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/philox.glsl"
layout(local_size_x = 256) in;

// gpu::BloomParams (gpu/kernels.h): src = acc_1, dst = the image; a = keep, b = spread
layout(push_constant, std430) uniform Params {
  int src_w, src_h, dst_w, dst_h;
  int mode;
  float a, b;
  float weights[7];
} P;
layout(std430, binding = 0) readonly buffer Coarse { float coarse[]; };
layout(std430, binding = 1) buffer Img { float img[]; };

void main() {
  const uint i = linear_invocation();
  if (i >= uint(P.dst_w * P.dst_h)) return;
  const int x = int(i % uint(P.dst_w)), y = int(i / uint(P.dst_w));
  const int aw = P.src_w, ah = P.src_h;
  const double sx = double(aw) / double(P.dst_w), sy = double(ah) / double(P.dst_h);
  const double fx = clamp((double(x) + 0.5lf) * sx - 0.5lf, 0.0lf, double(aw - 1));
  const double fy = clamp((double(y) + 0.5lf) * sy - 0.5lf, 0.0lf, double(ah - 1));
  const int x0 = int(fx), x1 = min(aw - 1, x0 + 1), y0 = int(fy), y1 = min(ah - 1, y0 + 1);
  const float wx = float(fx - double(x0)), wy = float(fy - double(y0));
  for (int c = 0; c < 3; ++c) {
    precise float a0 = coarse[3 * (y0 * aw + x0) + c], a1 = coarse[3 * (y1 * aw + x0) + c];
    precise float b0 = coarse[3 * (y0 * aw + x1) + c], b1 = coarse[3 * (y1 * aw + x1) + c];
    precise float ra = P.b * (a0 + (a1 - a0) * wy);
    precise float rb = P.b * (b0 + (b1 - b0) * wy);
    precise float o = P.a * img[3 * i + c] + ra + (rb - ra) * wx;
    img[3 * i + c] = o;
  }
}
