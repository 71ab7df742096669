// Bilinear demosaic of the black-subtracted mosaic, photosite::demosaic_bilinear operation for
// operation: per filter colour, the [1 2 1; 2 4 2; 1 2 1]-weighted mean of the in-frame 3x3
// neighbours of that colour, then filter_planes_to_rgb (planes R, G, B, C → R, G, B).
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/cfa.glsl"
#include "common/philox.glsl"
layout(local_size_x = 256) in;

// gpu::DemosaicParams (gpu/kernels.h)
layout(push_constant, std430) uniform Params {
  uint width;
  uint height;
  uint cfa_cell;
  uint planes_to_rgb;  // 0 R,G,B planes; 1 RCCB (G = C − R − B); 2 RCCC (G = B = (C − R)/2); 3 mono (C/3)
  float black_dn;      // subtracted from every mosaic sample first
} P;
layout(std430, binding = 0) readonly buffer Raw { float raw_dn[]; };
layout(std430, binding = 1) writeonly buffer Rgb { float rgb[]; };

void main() {
  const uint i = linear_invocation();
  if (i >= P.width * P.height) return;
  const int x = int(i % P.width), y = int(i / P.width), w = int(P.width), h = int(P.height);
  precise float sum[4] = float[4](0.0, 0.0, 0.0, 0.0);
  precise float wsum[4] = float[4](0.0, 0.0, 0.0, 0.0);
  for (int dy = -1; dy <= 1; ++dy) {
    const int yy = y + dy;
    if (yy < 0 || yy >= h) continue;
    for (int dx = -1; dx <= 1; ++dx) {
      const int xx = x + dx;
      if (xx < 0 || xx >= w) continue;
      const uint c = cfa_color(P.cfa_cell, uint(xx), uint(yy));
      const float kw = float((2 - abs(dx)) * (2 - abs(dy)));
      precise float v = raw_dn[yy * w + xx] - P.black_dn;
      sum[c] += kw * v;
      wsum[c] += kw;
    }
  }
  precise float planes[4];
  for (int c = 0; c < 4; ++c) planes[c] = wsum[c] > 0.0 ? sum[c] / wsum[c] : 0.0;
  precise vec3 o;
  if (P.planes_to_rgb == 1u) o = vec3(planes[0], planes[3] - planes[0] - planes[2], planes[2]);
  else if (P.planes_to_rgb == 2u) o = vec3(planes[0], vec2(0.5 * (planes[3] - planes[0])));
  else if (P.planes_to_rgb == 3u) o = vec3(planes[3] / 3.0);
  else o = vec3(planes[0], planes[1], planes[2]);
  rgb[3 * i] = o.x;
  rgb[3 * i + 1] = o.y;
  rgb[3 * i + 2] = o.z;
}
