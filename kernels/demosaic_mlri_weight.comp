// MLRI green combination, weights (direction P.dir): 1 / (S^2 + 1e-32), S the 3x3 sum (rows of
// 3 along x, then the 3 rows) of |dif(-1) - dif(+1)| along the direction (GBTF / RI weights).
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/mlri.glsl"

float grad(int x, int y) {
  precise float g = P.dir == 0u ? abs(dif[pidx(0, x - 1, y)] - dif[pidx(0, x + 1, y)])
                                : abs(dif[pidx(1, x, y - 1)] - dif[pidx(1, x, y + 1)]);
  return g;
}
float row3(int x, int y) {
  precise float s = (grad(x - 1, y) + grad(x, y)) + grad(x + 1, y);
  return s;
}

void main() {
  int x, y;
  if (!region_setup(x, y)) return;
  precise float s = (row3(x, y - 1) + row3(x, y)) + row3(x, y + 1);
  precise float w = div_rn(1.0, s * s + 1e-32);
  wt[pidx(int(P.dir), x, y)] = w;
}
