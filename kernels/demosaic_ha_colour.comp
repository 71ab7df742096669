// Hamilton-Adams demosaic, pass 2 (sensor/demosaic_ha.cpp, HaColour, operation for operation): red
// and blue from the smooth colour differences G - R and G - B over the green plane of pass 1; at
// R/B sites along the diagonal with the smaller gradient, at green sites from the two neighbours
// of each colour. RCCB then G = C - R - B.
#version 450
#extension GL_GOOGLE_include_directive : enable
#define DEMOSAIC_RGB_MAIN
#include "common/demosaic.glsl"
layout(std430, binding = 2) readonly buffer Green { float green[]; };

// The green plane at (x, y), mirrored like the mosaic (it is not black-offset).
float gfetch(int x, int y) { return green[reflect101(y, H) * W + reflect101(x, W)]; }
float diff(int x, int y) { return gfetch(x, y) - fetch(x, y); }  // G - colour

vec3 bayer_px(int x, int y, int t) {
  precise float c = fetch(x, y);
  precise float g = gfetch(x, y);
  precise vec3 o;
  if (t == 0 || t == 3) {
    precise float a1 = fetch(x - 1, y - 1), a2 = fetch(x + 1, y + 1), b1 = fetch(x + 1, y - 1), b2 = fetch(x - 1, y + 1);
    precise float ga1 = gfetch(x - 1, y - 1), ga2 = gfetch(x + 1, y + 1), gb1 = gfetch(x + 1, y - 1),
                  gb2 = gfetch(x - 1, y + 1);
    precise float grad_a = abs(a1 - a2) + abs(2.0 * g - ga1 - ga2);
    precise float grad_b = abs(b1 - b2) + abs(2.0 * g - gb1 - gb2);
    precise float da = 0.5 * ((ga1 - a1) + (ga2 - a2));
    precise float db = 0.5 * ((gb1 - b1) + (gb2 - b2));
    precise float other = g - (grad_a < grad_b ? da : (grad_b < grad_a ? db : 0.5 * (da + db)));
    o = t == 0 ? vec3(c, g, other) : vec3(other, g, c);
  } else {
    precise float dl = diff(x - 1, y), dr = diff(x + 1, y), du = diff(x, y - 1), dd = diff(x, y + 1);
    precise float horiz = g - 0.5 * (dl + dr);
    precise float vert = g - 0.5 * (du + dd);
    o = t == 1 ? vec3(horiz, c, vert) : vec3(vert, c, horiz);
  }
  return o;
}

void main() { demosaic_main(); }
