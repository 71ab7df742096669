// Malvar-He-Cutler gradient-corrected bilinear demosaic (Malvar, He, Cutler, ICASSP 2004), the
// eight 5x5 filters of sensor/demosaic_malvar.cpp (MalvarKernel) operation for operation: each
// missing colour is its bilinear estimate plus a gain times the Laplacian of the colour present
// at the pixel. The frame (borders, RCCB, the generic path) is common/demosaic.glsl.
#version 450
#extension GL_GOOGLE_include_directive : enable
#define DEMOSAIC_RGB_MAIN
#include "common/demosaic.glsl"

vec3 bayer_px(int x, int y, int t) {
  precise float c = fetch(x, y);
  precise float l = fetch(x - 1, y), r = fetch(x + 1, y), u = fetch(x, y - 1), d = fetch(x, y + 1);
  precise float l2 = fetch(x - 2, y), r2 = fetch(x + 2, y), u2 = fetch(x, y - 2), d2 = fetch(x, y + 2);
  precise float diag = (fetch(x - 1, y - 1) + fetch(x + 1, y - 1)) + (fetch(x - 1, y + 1) + fetch(x + 1, y + 1));
  precise float h2 = l2 + r2;
  precise float v2 = u2 + d2;
  precise vec3 o;
  if (t == 0 || t == 3) {
    precise float g = 0.125 * (4.0 * c + 2.0 * ((l + r) + (u + d)) - (h2 + v2));
    precise float other = 0.125 * (6.0 * c + 2.0 * diag - 1.5 * (h2 + v2));
    o = t == 0 ? vec3(c, g, other) : vec3(other, g, c);
  } else {
    precise float horiz = 0.125 * (5.0 * c + 4.0 * (l + r) - h2 - diag + 0.5 * v2);
    precise float vert = 0.125 * (5.0 * c + 4.0 * (u + d) - v2 - diag + 0.5 * h2);
    o = t == 1 ? vec3(horiz, c, vert) : vec3(vert, c, horiz);
  }
  return o;
}

void main() { demosaic_main(); }
