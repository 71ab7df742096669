// Shared by the LMMSE demosaic kernels (demosaic_lmmse_*.comp), the device twin of
// sensor/demosaic_lmmse.cpp (Zhang & Wu, IEEE TIP 2005): the parameters (gpu::LmmseParams: the
// demosaic frame plus the 9 Gaussian weights, sigma 2, as the C++ code computes them; defined in
// common/params_demosaic.glsl) and the scratch planes. Each plane is one float per pixel of its
// own width: dv, sv (vertical observations and their low-pass) w wide; zh (horizontal
// observations) w + 16 wide from x = -8; sh (their low-pass) w + 8 wide from x = -4; d (the fused
// G - X) w wide.
#ifndef PHOTOSITE_LMMSE_GLSL
#define PHOTOSITE_LMMSE_GLSL
#define DEMOSAIC_PARAMS_LMMSE  // P: the frame, then gw (common/params_demosaic.glsl)
#include "demosaic.glsl"

const int kHalf = 4;

// Sign of Delta = G - X: +1 at R/B sites (X observed), -1 at green sites.
float delta_sign(int x, int y) { int t = cell_type(x, y); return (t == 0 || t == 3) ? 1.0 : -1.0; }

// The 1-D observation of Delta from five samples along a line (a, b, c, d, e; c the centre):
// [-1 2 2 2 -1]/4 estimates the missing colour, in the C++ order.
float observation(float a, float b, float c, float d, float e, float sg) {
  precise float t = 0.25 * (2.0 * (b + c + d) - a - e) - c;
  precise float r = sg * t;
  return r;
}
#endif
