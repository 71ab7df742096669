// MLRI green combination: at R/B sites, green = mosaic + the weighted mean of the one-sided
// 5-tap Gaussian means of the directional differences towards W, E (horizontal) and N, S
// (vertical), weighted by the neighbours' weights; green sites keep the mosaic value.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/mlri.glsl"

void main() {
  int x, y;
  if (!region_setup(x, y)) return;
  phase_setup();
  const float r = fetch(x, y);
  if (!rb_site(x, y)) {
    green[pidx(0, x, y)] = r;
    return;
  }
  const float Ww = wt[pidx(0, x - 1, y)], We = wt[pidx(0, x + 1, y)];
  const float Wn = wt[pidx(1, x, y - 1)], Ws = wt[pidx(1, x, y + 1)];
  precise float dw = P.gw[0] * dif[pidx(0, x - 4, y)], de = P.gw[0] * dif[pidx(0, x + 4, y)];
  precise float dn = P.gw[0] * dif[pidx(1, x, y - 4)], ds = P.gw[0] * dif[pidx(1, x, y + 4)];
  for (int j = 1; j < 5; ++j) {
    dw += P.gw[j] * dif[pidx(0, x - 4 + j, y)];
    de += P.gw[j] * dif[pidx(0, x + 4 - j, y)];
    dn += P.gw[j] * dif[pidx(1, x, y - 4 + j)];
    ds += P.gw[j] * dif[pidx(1, x, y + 4 - j)];
  }
  precise float d = div_rn(((Wn * dn + Ws * ds) + Ww * dw) + We * de, ((Wn + Ws) + Ww) + We);
  precise float g = r + d;
  green[pidx(0, x, y)] = g;
}
