// The frame of every demosaic kernel (demosaic_<method>.comp), mirroring sensor/demosaic.cpp and
// sensor/demosaic_detail.h: parameters, buffers, reflect-101 borders, the red site's phase, the
// normalized-convolution bilinear path for RCCC, mono and frames under 2x2
// (demosaic_bilinear_generic), RCCB's clear samples at green's level and G = C - R - B
// (common/clear_level.glsl; the bilinear kernel defines DEMOSAIC_CLEAR_AT_CLEAR_LEVEL, as
// sensor/demosaic.cpp's bilinear reads C as it is). The mosaic is binding 0; a kernel declares
// its outputs (and further inputs) itself. A one-pass method's .comp defines DEMOSAIC_RGB_MAIN
// before including this file, defines `vec3 bayer_px(int x, int y, int t)` (the pixel of RGGB cell
// type t: 0 R, 1 G in a red row, 2 G in a blue row, 3 B, summed in the C++ kernel's order), and
// calls demosaic_main() from main(); multi-pass methods use the pieces (frame_setup, cell_type).
#ifndef PHOTOSITE_DEMOSAIC_GLSL
#define PHOTOSITE_DEMOSAIC_GLSL
#include "cfa.glsl"
#include "philox.glsl"
layout(local_size_x = 256) in;

// The push constants P: the frame, and the method's own parameters after it where the including
// file defined DEMOSAIC_PARAMS_LMMSE or DEMOSAIC_PARAMS_MLRI (common/params_demosaic.glsl).
#include "params_demosaic.glsl"
layout(std430, binding = 0) readonly buffer Raw { float raw_dn[]; };

// reflect101: common/border.glsl; the clear level: common/clear_level.glsl; both shared with
// the C++ kernels (sensor/demosaic_detail.h).
#include "prelude.glsl"
#include "border.glsl"
#include "clear_level.glsl"
#include "prelude_end.glsl"

int W, H;
// RCCB's clear sites (FilterColor::C).
bool clear_site(int x, int y) { return P.planes_to_rgb == 1u && cfa_color(P.cfa_cell, uint(x), uint(y)) == 3u; }
// The black-subtracted mosaic sample at (x, y) of the frame.
float mosaic_at(int x, int y) { return raw_dn[y * W + x] - P.black_dn; }
// The same, mirrored at the borders; on the Bayer path of RCCB, a clear sample at green's level
// (detail::GreenLevelMosaic) unless the kernel reads C as it is (bilinear).
float fetch(int x, int y) {
  const int xr = reflect101(x, W), yr = reflect101(y, H);
  precise float v = mosaic_at(xr, yr);
#ifndef DEMOSAIC_CLEAR_AT_CLEAR_LEVEL
  if (clear_site(xr, yr)) v = clear_to_green_level(v);
#endif
  return v;
}

// Sets W, H; false for invocations past the frame.
bool frame_setup(uint i) {
  W = int(P.width);
  H = int(P.height);
  return i < P.width * P.height;
}

// The RGGB cell type of (x, y) (demosaic_detail.h cell_type), the red site's position in the 2x2
// cell found from the packed pattern (bayer_phase()).
int cell_type(int x, int y) {
  int ox = 0, oy = 0;
  for (int c = 0; c < 4; ++c)
    if (cfa_color(P.cfa_cell, uint(c & 1), uint(c >> 1)) == 0u) {
      ox = c & 1;
      oy = c >> 1;
    }
  return (((y - oy) & 1) << 1) | ((x - ox) & 1);
}

// The mirrored Bayer path applies (bayer_path_ok): RGGB family or RCCB, at least 2x2.
bool bayer_path() { return P.planes_to_rgb <= 1u && W >= 2 && H >= 2; }

vec3 generic_px(int x, int y) {
  precise float sum[4] = float[4](0.0, 0.0, 0.0, 0.0);
  precise float wsum[4] = float[4](0.0, 0.0, 0.0, 0.0);
  for (int dy = -1; dy <= 1; ++dy) {
    const int yy = y + dy;
    if (yy < 0 || yy >= H) continue;
    for (int dx = -1; dx <= 1; ++dx) {
      const int xx = x + dx;
      if (xx < 0 || xx >= W) continue;
      const uint c = cfa_color(P.cfa_cell, uint(xx), uint(yy));
      const float kw = float((2 - abs(dx)) * (2 - abs(dy)));
      precise float v = raw_dn[yy * W + xx] - P.black_dn;
      sum[c] += kw * v;
      wsum[c] += kw;
    }
  }
  precise float planes[4];
  for (int c = 0; c < 4; ++c) planes[c] = wsum[c] > 0.0 ? div_rn(sum[c], wsum[c]) : 0.0;
  precise vec3 o;
  if (P.planes_to_rgb == 1u) o = vec3(planes[0], planes[3] - planes[0] - planes[2], planes[2]);
  else if (P.planes_to_rgb == 2u) o = vec3(planes[0], vec2(0.5 * (planes[3] - planes[0])));
  else if (P.planes_to_rgb == 3u) o = vec3(div_rn(planes[3], 3.0));
  else o = vec3(planes[0], planes[1], planes[2]);
  return o;
}

#ifdef DEMOSAIC_RGB_MAIN
layout(std430, binding = 1) writeonly buffer Rgb { float rgb[]; };
vec3 bayer_px(int x, int y, int t);

void write_rgb(uint i, vec3 o) {
  rgb[3 * i] = o.x;
  rgb[3 * i + 1] = o.y;
  rgb[3 * i + 2] = o.z;
}

void demosaic_main() {
  const uint i = linear_invocation();
  if (!frame_setup(i)) return;
  const int x = int(i % P.width), y = int(i / P.width);
  precise vec3 o;
  if (bayer_path()) {
    o = bayer_px(x, y, cell_type(x, y));
#ifdef DEMOSAIC_CLEAR_AT_CLEAR_LEVEL
    if (P.planes_to_rgb == 1u) o.y = o.y - o.x - o.z;  // clear_to_rgb
#else
    if (P.planes_to_rgb == 1u) o.y = rccb_green(clear_site(x, y), mosaic_at(x, y), o.y, o.x, o.z);  // finish()
#endif
  } else {
    o = generic_px(x, y);
  }
  write_rgb(i, o);
}
#endif
#endif
