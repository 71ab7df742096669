// MLRI red/blue, stage 1: the products of the 5-point cross Laplacians (step 2) of green and of
// the mosaic: L(G) L(p), L(G)^2.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/mlri.glsl"

float gr(int x, int y) { return green[pidx(0, x, y)]; }

void main() {
  int x, y;
  if (!region_setup(x, y)) return;
  precise float li = (((4.0 * gr(x, y) - gr(x - 2, y)) - gr(x + 2, y)) - gr(x, y - 2)) - gr(x, y + 2);
  precise float lp = (((4.0 * fetch(x, y) - fetch(x - 2, y)) - fetch(x + 2, y)) - fetch(x, y - 2)) - fetch(x, y + 2);
  precise float lip = li * lp, lii = li * li;
  lap[pidx(0, x, y)] = lip;
  lap[pidx(1, x, y)] = lii;
}
