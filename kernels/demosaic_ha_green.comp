// Hamilton-Adams demosaic, pass 1 (sensor/demosaic_ha.cpp, HaGreen, operation for operation): the
// full green plane. At R/B sites green is interpolated along the row or the column, whichever has
// the smaller gradient (|first difference of green| + |second difference of the centre colour|),
// each estimate the green mean plus a quarter of the centre colour's Laplacian; the mean of both
// on a tie. Only for frames on the mirrored Bayer path (the host runs the bilinear kernel's
// generic path otherwise, as the C++ code does).
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/demosaic.glsl"
layout(std430, binding = 1) writeonly buffer Green { float green[]; };

void main() {
  const uint i = linear_invocation();
  if (!frame_setup(i)) return;
  const int x = int(i % P.width), y = int(i / P.width);
  const int t = cell_type(x, y);
  precise float c = fetch(x, y);
  if (t == 1 || t == 2) {
    green[i] = c;
    return;
  }
  precise float l = fetch(x - 1, y), r = fetch(x + 1, y), u = fetch(x, y - 1), d = fetch(x, y + 1);
  precise float lap_h = 2.0 * c - fetch(x - 2, y) - fetch(x + 2, y);
  precise float lap_v = 2.0 * c - fetch(x, y - 2) - fetch(x, y + 2);
  precise float grad_h = abs(l - r) + abs(lap_h);
  precise float grad_v = abs(u - d) + abs(lap_v);
  precise float gh = 0.5 * (l + r) + 0.25 * lap_h;
  precise float gv = 0.5 * (u + d) + 0.25 * lap_v;
  green[i] = grad_h < grad_v ? gh : (grad_v < grad_h ? gv : 0.5 * (gh + gv));
}
