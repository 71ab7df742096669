// MLRI, last stage: per site type the measured value, or the tentative estimate plus the bilinear
// interpolation of the residuals (mosaic - tentative of the R sites in red rows, of the B sites in
// blue rows) from the left/right, up/down or diagonal neighbours; RCCB then G = C - R - B, C from
// green's level (common/clear_level.glsl).
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/mlri.glsl"
layout(std430, binding = 7) writeonly buffer Rgb { float rgb[]; };

float res(int x, int y) {
  const bool red_row = ((y - red_oy) & 1) == 0;
  precise float r = fetch(x, y) - tent[pidx(red_row ? 0 : 1, x, y)];
  return r;
}

void main() {
  int x, y;
  if (!region_setup(x, y)) return;  // dispatched with mx = my = 0
  phase_setup();
  const float r = fetch(x, y), g = green[pidx(0, x, y)];
  const float qr = tent[pidx(0, x, y)], qb = tent[pidx(1, x, y)];
  precise float h_res = 0.5 * (res(x - 1, y) + res(x + 1, y));
  precise float v_res = 0.5 * (res(x, y - 1) + res(x, y + 1));
  precise float d_res = 0.25 * ((res(x - 1, y - 1) + res(x + 1, y - 1)) + (res(x - 1, y + 1) + res(x + 1, y + 1)));
  const bool first = (x & 1) == (red_ox & 1);
  precise float R, B;
  if (((y - red_oy) & 1) == 0) {
    R = first ? r : qr + h_res;
    B = qb + (first ? d_res : v_res);
  } else {
    R = qr + (first ? v_res : d_res);
    B = first ? qb + h_res : r;
  }
  precise float G = P.planes_to_rgb == 1u ? rccb_green(clear_site(x, y), mosaic_at(x, y), g, R, B) : g;
  const uint i = uint(y) * P.width + uint(x);
  rgb[3 * i] = R;
  rgb[3 * i + 1] = G;
  rgb[3 * i + 2] = B;
}
