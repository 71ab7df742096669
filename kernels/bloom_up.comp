// Collapsing the bloom chain one level finer: acc_l = blurred_l + up(acc_{l+1}), the
// upsampling bilinear with pixel-centre alignment (cv::resize INTER_LINEAR):
//   f = (x + ½)·(src/dst) − ½, clamped to [0, src − 1].
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/philox.glsl"
layout(local_size_x = 256) in;

// gpu::BloomParams (gpu/kernels.h): src = the coarse acc, dst = this level
layout(push_constant, std430) uniform Params {
  int src_w, src_h, dst_w, dst_h;
  int mode;
  float a, b;
  float weights[7];
} P;
layout(std430, binding = 0) readonly buffer Coarse { float coarse[]; };
layout(std430, binding = 1) buffer Acc { float acc[]; };  // in: blurred_l, out: acc_l

vec3 at(int x, int y) { const int s = 3 * (y * P.src_w + x); return vec3(coarse[s], coarse[s + 1], coarse[s + 2]); }

void main() {
  const uint i = linear_invocation();
  if (i >= uint(P.dst_w * P.dst_h)) return;
  const int x = int(i % uint(P.dst_w)), y = int(i / uint(P.dst_w));
  const float fx = clamp((float(x) + 0.5) * float(P.src_w) / float(P.dst_w) - 0.5, 0.0, float(P.src_w - 1));
  const float fy = clamp((float(y) + 0.5) * float(P.src_h) / float(P.dst_h) - 0.5, 0.0, float(P.src_h - 1));
  const int x0 = int(fx), y0 = int(fy), x1 = min(x0 + 1, P.src_w - 1), y1 = min(y0 + 1, P.src_h - 1);
  const float wx = fx - float(x0), wy = fy - float(y0);
  const vec3 up = mix(mix(at(x0, y0), at(x1, y0), wx), mix(at(x0, y1), at(x1, y1), wx), wy);
  acc[3 * i] += up.x;
  acc[3 * i + 1] += up.y;
  acc[3 * i + 2] += up.z;
}
