// Bilinear demosaic of the black-subtracted mosaic, photosite::demosaic_bilinear operation for
// operation (sensor/demosaic.cpp). Bayer-geometry patterns (RGGB family, RCCB) of at least 2x2
// take the fast path's formulas (BilinearKernel) on a reflect-101 mirrored border: each missing
// colour the mean of its nearest 2 or 4 samples, summed in the same order as the C++ code; RCCB
// then G = C - R - B. RCCC, mono and 1-pixel-wide frames take the normalized convolution of
// demosaic_bilinear_generic: per filter colour the [1 2 1; 2 4 2; 1 2 1]-weighted mean of the
// in-frame 3x3 neighbours of that colour, then filter_planes_to_rgb.
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

// demosaic_detail.h reflect(): reflect-101 into [0, n), n >= 2 (keeps parity).
int reflect101(int i, int n) {
  if (i >= 0 && i < n) return i;
  const int period = 2 * (n - 1);
  i %= period;
  if (i < 0) i += period;
  return i < n ? i : period - i;
}

int W, H;
float fetch(int x, int y) { return raw_dn[reflect101(y, H) * W + reflect101(x, W)] - P.black_dn; }

vec3 bayer(int x, int y) {
  // The red site's position in the 2x2 cell, from the packed pattern.
  int ox = 0, oy = 0;
  for (int c = 0; c < 4; ++c)
    if (cfa_color(P.cfa_cell, uint(c & 1), uint(c >> 1)) == 0u) { ox = c & 1; oy = c >> 1; }
  const int t = (((y - oy) & 1) << 1) | ((x - ox) & 1);  // 0 R, 1 G in a red row, 2 G in a blue row, 3 B
  precise float c = fetch(x, y);
  precise float lr = fetch(x - 1, y) + fetch(x + 1, y);
  precise float ud = fetch(x, y - 1) + fetch(x, y + 1);
  precise vec3 o;
  if (t == 0 || t == 3) {
    precise float diag = (fetch(x - 1, y - 1) + fetch(x + 1, y - 1)) + (fetch(x - 1, y + 1) + fetch(x + 1, y + 1));
    precise float other = 0.25 * diag;
    precise float g = 0.25 * (lr + ud);
    o = t == 0 ? vec3(c, g, other) : vec3(other, g, c);
  } else {
    precise float h2 = 0.5 * lr;
    precise float v2 = 0.5 * ud;
    o = t == 1 ? vec3(h2, c, v2) : vec3(v2, c, h2);
  }
  if (P.planes_to_rgb == 1u) o.y = o.y - o.x - o.z;
  return o;
}

void main() {
  const uint i = linear_invocation();
  if (i >= P.width * P.height) return;
  const int x = int(i % P.width), y = int(i / P.width), w = int(P.width), h = int(P.height);
  W = w;
  H = h;
  if (P.planes_to_rgb <= 1u && w >= 2 && h >= 2) {
    const vec3 o = bayer(x, y);
    rgb[3 * i] = o.x;
    rgb[3 * i + 1] = o.y;
    rgb[3 * i + 2] = o.z;
    return;
  }
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
