// LMMSE pass 5 (sensor/demosaic_lmmse.cpp, LmmseColour, operation for operation): green is the
// mosaic plus the fused difference d at R/B sites; the missing R/B are green minus the mean
// difference of the nearest sites of that colour. RCCB then G = C - R - B.
#version 450
#extension GL_GOOGLE_include_directive : enable
#define DEMOSAIC_RGB_MAIN
#include "common/lmmse.glsl"
layout(std430, binding = 2) readonly buffer D { float d[]; };

float dfetch(int x, int y) { return d[reflect101(y, H) * W + reflect101(x, W)]; }
// Mean d over the diagonal neighbours of (x, y).
float diag(int x, int y) {
  precise float r = 0.25 * ((dfetch(x - 1, y - 1) + dfetch(x + 1, y - 1)) + (dfetch(x - 1, y + 1) + dfetch(x + 1, y + 1)));
  return r;
}

vec3 bayer_px(int x, int y, int t) {
  precise float c = fetch(x, y);
  precise float g = c + dfetch(x, y);
  precise vec3 o;
  if (t == 0 || t == 3) {
    precise float other = g - diag(x, y);
    o = t == 0 ? vec3(c, g, other) : vec3(other, g, c);
  } else {
    precise float dh_own = dfetch(x - 1, y) + dfetch(x + 1, y);
    precise float dv_own = dfetch(x, y - 1) + dfetch(x, y + 1);
    precise float dh_x = diag(x - 1, y) + diag(x + 1, y);
    precise float dv_x = diag(x, y - 1) + diag(x, y + 1);
    precise float horiz = g - 0.25 * (dh_own + dv_x);
    precise float vert = g - 0.25 * (dv_own + dh_x);
    o = t == 1 ? vec3(horiz, c, vert) : vec3(vert, c, horiz);
  }
  return o;
}

void main() { demosaic_main(); }
