// MLRI red/blue, stage 3: the 5x5 box sums of the R and B coefficients (rows of 5 in increasing
// x, then the 5 rows in increasing y) and the tentative estimates q = (sum a G + sum b) / 25.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/mlri.glsl"

float hbox(int p, int x, int y) {
  precise float s = coef[pidx(p, x - kRb, y)];
  for (int d = -kRb + 1; d <= kRb; ++d) s += coef[pidx(p, x + d, y)];
  return s;
}

void main() {
  int x, y;
  if (!region_setup(x, y)) return;
  const float g = green[pidx(0, x, y)];
  for (int cls = 0; cls < 2; ++cls) {
    precise float sa = hbox(2 * cls, x, y - kRb), sb = hbox(2 * cls + 1, x, y - kRb);
    for (int d = -kRb + 1; d <= kRb; ++d) {
      sa += hbox(2 * cls, x, y + d);
      sb += hbox(2 * cls + 1, x, y + d);
    }
    precise float q = (sa * g + sb) * P.inv_box_b;
    tent[pidx(cls, x, y)] = q;
  }
}
