// MLRI green, stage 1 (direction P.dir; demosaic_mlri_body.inc green_direction): the products of
// the step-2 Laplacians [-1 0 2 0 -1] along the direction of the guide (the 2-tap mean of the
// neighbours along it) and of the mosaic: L(I) L(p) and L(I)^2.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/mlri.glsl"

void main() {
  int x, y;
  if (!region_setup(x, y)) return;
  precise float li = (2.0 * guide(x, y, 0) - guide(x, y, -2)) - guide(x, y, 2);
  precise float lp = (2.0 * raw_along(x, y, 0) - raw_along(x, y, -2)) - raw_along(x, y, 2);
  precise float lip = li * lp, lii = li * li;
  lap[pidx(0, x, y)] = lip;
  lap[pidx(1, x, y)] = lii;
}
