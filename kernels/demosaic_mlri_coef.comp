// MLRI green, stage 2 (direction P.dir): the coefficients (a, b) of the two site relations over
// the 9-sample window along the direction (relation 0: the offsets of even parity -4..4, 1: the
// odd ones -3..3), stored per site class (the parity of the coordinate along the direction): a0,
// a1, b0, b1. The sums in demosaic_mlri_body.inc's order, which shares pairs v(o) + v(o + 2):
// relation 0 ((v(-4) + v(-2)) + (v(0) + v(2))) + v(4), relation 1 (v(-3) + v(-1)) + (v(1) + v(3)).
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/mlri.glsl"

// The four window quantities at offset d along the direction: guide, mosaic, L(I)L(p), L(I)^2.
float quantity(int q, int x, int y, int d) {
  if (q == 0) return guide(x, y, d);
  if (q == 1) return raw_along(x, y, d);
  return lap_along(q - 2, x, y, d);
}
float pair(int q, int x, int y, int d) {
  precise float s = quantity(q, x, y, d) + quantity(q, x, y, d + 2);
  return s;
}

void main() {
  int x, y;
  if (!region_setup(x, y)) return;
  precise float s0[4], s1[4];
  for (int q = 0; q < 4; ++q) {
    s0[q] = (pair(q, x, y, -4) + pair(q, x, y, 0)) + quantity(q, x, y, 4);
    s1[q] = pair(q, x, y, -3) + pair(q, x, y, 1);
  }
  float a[2], b[2];
  coefficients(s0[0], s0[1], s0[2], s0[3], P.tau_n_g[0], P.inv_n_g[0], a[0], b[0]);
  coefficients(s1[0], s1[1], s1[2], s1[3], P.tau_n_g[1], P.inv_n_g[1], a[1], b[1]);
  const bool even = ((P.dir == 0u ? x : y) & 1) == 0;
  coef[pidx(0, x, y)] = even ? a[0] : a[1];
  coef[pidx(1, x, y)] = even ? a[1] : a[0];
  coef[pidx(2, x, y)] = even ? b[0] : b[1];
  coef[pidx(3, x, y)] = even ? b[1] : b[0];
}
