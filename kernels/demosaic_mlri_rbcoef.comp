// MLRI red/blue, stage 2: the coefficients (a, b) of the R sites and of the B sites at every
// pixel, over the 5x5 window: per row of the class's row parity (in increasing order) the sum
// over the class's columns (centre parity: -2, 0, 2; other: -1, 1), then the column sum.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/mlri.glsl"

float quantity(int q, int x, int y) {
  if (q == 0) return green[pidx(0, x, y)];
  if (q == 1) return fetch(x, y);
  return lap[pidx(q - 2, x, y)];
}
// The sum over the columns of parity `same` (the centre's) or the other, in increasing x.
float hsum(int q, int x, int y, bool same) {
  precise float s;
  if (same) {
    s = quantity(q, x - 2, y);
    s += quantity(q, x, y);
    s += quantity(q, x + 2, y);
  } else {
    s = quantity(q, x - 1, y);
    s += quantity(q, x + 1, y);
  }
  return s;
}

void main() {
  int x, y;
  if (!region_setup(x, y)) return;
  phase_setup();
  const int xpar_r = red_ox & 1;
  for (int cls = 0; cls < 2; ++cls) {
    const int ky = ((y - red_oy) & 1) ^ cls, xpar = xpar_r ^ cls;
    const bool same = (x & 1) == xpar;  // the class's columns have the centre's parity
    precise float s[4];
    for (int q = 0; q < 4; ++q) {
      bool first = true;
      for (int d = -kRb; d <= kRb; ++d) {
        if ((d & 1) != ky) continue;
        precise float h = hsum(q, x, y + d, same);
        if (first) {
          s[q] = h;
          first = false;
        } else {
          s[q] += h;
        }
      }
    }
    const int k = ky << 1;
    const float tn = same ? P.tau_n_b[k] : P.tau_n_b[k | 1], in_ = same ? P.inv_n_b[k] : P.inv_n_b[k | 1];
    float a, b;
    coefficients(s[0], s[1], s[2], s[3], tn, in_, a, b);
    coef[pidx(2 * cls, x, y)] = a;
    coef[pidx(2 * cls + 1, x, y)] = b;
  }
}
