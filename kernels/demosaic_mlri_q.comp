// MLRI green, stage 3 (direction P.dir): the 9-sample box sums of the class coefficients along
// the direction, as three 3-sample sums ((c(o-1) + c(o)) + c(o+1) at o = -3, 0, 3, added in that
// order), and the tentative estimates of the pixel's own class (guide: the 2-tap mean) and of
// its partner along the direction (guide: the mosaic value).
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/mlri.glsl"

float box3(int p, int x, int y, int o) {
  precise float s = (coef_along(p, x, y, o - 1) + coef_along(p, x, y, o)) + coef_along(p, x, y, o + 1);
  return s;
}

void main() {
  int x, y;
  if (!region_setup(x, y)) return;
  precise float box[4];
  for (int p = 0; p < 4; ++p) box[p] = (box3(p, x, y, -3) + box3(p, x, y, 0)) + box3(p, x, y, 3);
  const bool even = ((P.dir == 0u ? x : y) & 1) == 0;
  precise float ao = even ? box[0] : box[1], bo = even ? box[2] : box[3];
  precise float ap = even ? box[1] : box[0], bp = even ? box[3] : box[2];
  precise float qo = (ao * guide(x, y, 0) + bo) * P.inv_box_g;
  precise float qp = (ap * fetch(x, y) + bp) * P.inv_box_g;
  tent[pidx(0, x, y)] = qo;
  tent[pidx(1, x, y)] = qp;
}
