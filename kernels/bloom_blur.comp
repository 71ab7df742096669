// One pass of the bloom's separable Gaussian (cv::GaussianBlur, σ = 1.5, 13 taps, reflect-101
// borders): mode 0 along rows, 1 along columns. Weights w[0..6] (centre first) come from the
// host, computed as cv::getGaussianKernel does (double, normalised, then float).
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/philox.glsl"
#include "common/image.glsl"
layout(local_size_x = 256) in;

// gpu::BloomParams (gpu/kernels.h)
layout(push_constant, std430) uniform Params {
  int src_w, src_h, dst_w, dst_h;
  int mode;
  float a, b;
  float weights[7];
} P;
layout(std430, binding = 0) readonly buffer Src { float src[]; };
layout(std430, binding = 1) writeonly buffer Dst { float dst[]; };

void main() {
  const uint i = linear_invocation();
  if (i >= uint(P.src_w * P.src_h)) return;
  const int x = int(i % uint(P.src_w)), y = int(i / uint(P.src_w));
  vec3 acc = vec3(0.0);
  for (int d = -6; d <= 6; ++d) {
    const int sx = P.mode == 0 ? reflect101(x + d, P.src_w) : x;
    const int sy = P.mode == 0 ? y : reflect101(y + d, P.src_h);
    const int s = 3 * (sy * P.src_w + sx);
    acc += P.weights[abs(d)] * vec3(src[s], src[s + 1], src[s + 2]);
  }
  dst[3 * i] = acc.x;
  dst[3 * i + 1] = acc.y;
  dst[3 * i + 2] = acc.z;
}
