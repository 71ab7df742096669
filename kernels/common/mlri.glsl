// Shared by the MLRI demosaic kernels (demosaic_mlri_*.comp), the device twin of
// sensor/demosaic_mlri.cpp and demosaic_mlri_body.inc (Kiku, Monno, Tanaka & Okutomi, SPIE 2014):
// the parameters (gpu::MlriParams: the demosaic frame, the stage's direction and margins, and
// the float constants as the C++ code computes them; defined in common/params_demosaic.glsl) and
// the scratch planes. Every plane covers the frame extended by `margin` pixels on each side (the
// mosaic mirrored there, reflect-101); a dispatch computes its stage over the frame plus
// (mx, my). Every sum is written in the C++ code's order (precise: no reassociation, no
// contraction), so the planes are bit-equal to the CPU's tile planes.
#ifndef PHOTOSITE_MLRI_GLSL
#define PHOTOSITE_MLRI_GLSL
#define DEMOSAIC_PARAMS_MLRI  // P: the frame, then MLRI's (common/params_demosaic.glsl)
#include "demosaic.glsl"

const int kRg = 4;  // green windows: 9 samples along the direction
const int kRb = 2;  // red/blue windows: 5x5

// Plane groups, each `n` planes of the extended frame.
layout(std430, binding = 1) buffer Lap { float lap[]; };      // 2: L(I)L(p), L(I)^2
layout(std430, binding = 2) buffer Coef { float coef[]; };    // 4: a0, a1, b0, b1 (green) / aR, bR, aB, bB
layout(std430, binding = 3) buffer Tent { float tent[]; };    // 2: tentative estimates
layout(std430, binding = 4) buffer Dif { float dif[]; };      // 2: horizontal, vertical colour differences
layout(std430, binding = 5) buffer Wt { float wt[]; };        // 2: horizontal, vertical weights
layout(std430, binding = 6) buffer Green { float green[]; };  // 1: green

int WE, HE;  // extended frame
int pidx(int p, int x, int y) { return p * (WE * HE) + (y + P.margin) * WE + (x + P.margin); }

// Sets W, H, WE, HE and the pixel (x, y) of invocation i over the frame plus (mx, my); false past it.
bool region_setup(out int x, out int y) {
  W = int(P.width);
  H = int(P.height);
  WE = W + 2 * P.margin;
  HE = H + 2 * P.margin;
  const uint i = linear_invocation();
  const uint rw = uint(W + 2 * P.mx), rh = uint(H + 2 * P.my);
  x = int(i % rw) - P.mx;
  y = int(i / rw) - P.my;
  return i < rw * rh;
}

// The mosaic at offset o along the stage's direction (0: x, 1: y) from (x, y), mirrored.
float raw_along(int x, int y, int o) { return P.dir == 0u ? fetch(x + o, y) : fetch(x, y + o); }
// The green stages' guide: the mean of the two neighbours along the direction.
float guide(int x, int y, int o) {
  precise float g = 0.5 * (raw_along(x, y, o - 1) + raw_along(x, y, o + 1));
  return g;
}
// Plane p at offset o along the direction.
float lap_along(int p, int x, int y, int o) { return P.dir == 0u ? lap[pidx(p, x + o, y)] : lap[pidx(p, x, y + o)]; }
float coef_along(int p, int x, int y, int o) { return P.dir == 0u ? coef[pidx(p, x + o, y)] : coef[pidx(p, x, y + o)]; }
float tent_along(int p, int x, int y, int o) { return P.dir == 0u ? tent[pidx(p, x + o, y)] : tent[pidx(p, x, y + o)]; }

// The MLRI coefficients from the window sums (demosaic_mlri_body.inc coefficient_row).
void coefficients(float si, float sp, float sip, float sii, float tn, float inv_n, out float a, out float b) {
  precise float t = (tn * si) * si;
  precise float den = max(sii, t);
  precise float ak = den > 0.0 ? div_rn(sip, den) : 0.0;
  precise float bk = (sp - ak * si) * inv_n;
  a = ak;
  b = bk;
}

// R/B sites: (x - ox) and (y - oy) of equal parity. The red site's phase (bayer_phase()).
int red_ox, red_oy;
void phase_setup() {
  red_ox = 0;
  red_oy = 0;
  for (int c = 0; c < 4; ++c)
    if (cfa_color(P.cfa_cell, uint(c & 1), uint(c >> 1)) == 0u) {
      red_ox = c & 1;
      red_oy = c >> 1;
    }
}
bool rb_site(int x, int y) { return (x & 1) == ((red_ox + y - red_oy) & 1); }
#endif
