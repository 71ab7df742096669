// One octave down the bloom mip chain (scene/lights.cpp bloom_in_place):
//   mode 0: area average (cv::resize INTER_AREA) onto a (w+1)/2 x (h+1)/2 grid: each output
//           pixel the coverage-weighted mean of the source pixels its footprint overlaps;
//   mode 1: 5x5 binomial Gaussian decimation ([1 4 6 4 1]/16 both ways, cv::pyrDown) with
//           reflect-101 borders.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/philox.glsl"
#include "common/image.glsl"
layout(local_size_x = 256) in;

// gpu::BloomParams (gpu/kernels.h)
layout(push_constant, std430) uniform Params {
  int src_w, src_h, dst_w, dst_h;
  int mode;        // down: 0 area, 1 pyrDown; blur: 0 horizontal, 1 vertical
  float a, b;      // mix: keep, spread
  float weights[7];
} P;
layout(std430, binding = 0) readonly buffer Src { float src[]; };
layout(std430, binding = 1) writeonly buffer Dst { float dst[]; };

void main() {
  const uint i = linear_invocation();
  if (i >= uint(P.dst_w * P.dst_h)) return;
  const int x = int(i % uint(P.dst_w)), y = int(i / uint(P.dst_w));
  vec3 acc = vec3(0.0);
  if (P.mode == 1) {
    const float k[5] = float[5](1.0, 4.0, 6.0, 4.0, 1.0);
    for (int dy = -2; dy <= 2; ++dy) {
      const int sy = reflect101(2 * y + dy, P.src_h);
      vec3 row = vec3(0.0);
      for (int dx = -2; dx <= 2; ++dx) {
        const int sx = reflect101(2 * x + dx, P.src_w);
        const int s = 3 * (sy * P.src_w + sx);
        row += k[dx + 2] * vec3(src[s], src[s + 1], src[s + 2]);
      }
      acc += k[dy + 2] * row;
    }
    acc *= 1.0 / 256.0;
  } else {
    // Footprint [x·sx, (x+1)·sx) x [y·sy, (y+1)·sy) in source pixels, sx = src_w / dst_w.
    const float sx = float(P.src_w) / float(P.dst_w), sy = float(P.src_h) / float(P.dst_h);
    const float x0 = float(x) * sx, x1 = min(float(x + 1) * sx, float(P.src_w));
    const float y0 = float(y) * sy, y1 = min(float(y + 1) * sy, float(P.src_h));
    float area = 0.0;
    for (int yy = int(floor(y0)); yy < int(ceil(y1)); ++yy) {
      const float wy = min(y1, float(yy + 1)) - max(y0, float(yy));
      for (int xx = int(floor(x0)); xx < int(ceil(x1)); ++xx) {
        const float wx = min(x1, float(xx + 1)) - max(x0, float(xx));
        const int s = 3 * (yy * P.src_w + xx);
        acc += (wx * wy) * vec3(src[s], src[s + 1], src[s + 2]);
        area += wx * wy;
      }
    }
    acc /= area;
  }
  dst[3 * i] = acc.x;
  dst[3 * i + 1] = acc.y;
  dst[3 * i + 2] = acc.z;
}
