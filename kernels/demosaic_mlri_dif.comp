// MLRI green, stage 4 (direction P.dir): the directional colour difference G - X as
// s (X_est - raw): X_est the partner's tentative estimate plus the mean of the residuals
// (raw - own tentative) of the two neighbours along the direction; s = +1 at R/B sites (X_est is
// green), -1 at green sites (X_est is the row's or column's R or B).
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/mlri.glsl"

void main() {
  int x, y;
  if (!region_setup(x, y)) return;
  phase_setup();
  precise float r0 = raw_along(x, y, -1) - tent_along(0, x, y, -1);
  precise float r1 = raw_along(x, y, 1) - tent_along(0, x, y, 1);
  precise float est = tent[pidx(1, x, y)] + 0.5 * (r0 + r1);
  precise float e = est - fetch(x, y);
  dif[pidx(int(P.dir), x, y)] = rb_site(x, y) ? e : -e;
}
