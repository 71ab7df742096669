// Bilinear demosaic of the black-subtracted mosaic, photosite::demosaic_bilinear operation for
// operation (sensor/demosaic.cpp, BilinearKernel): each missing colour the mean of its nearest 2
// or 4 samples of that colour. The frame (borders, RCCB, the generic path) is common/demosaic.glsl.
#version 450
#extension GL_GOOGLE_include_directive : enable
#define DEMOSAIC_RGB_MAIN
#define DEMOSAIC_CLEAR_AT_CLEAR_LEVEL  // each plane from its own samples: RCCB's C is read as it is
#include "common/demosaic.glsl"

vec3 bayer_px(int x, int y, int t) {
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
  return o;
}

void main() { demosaic_main(); }
