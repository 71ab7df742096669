// MLRI green, stage 2 (direction P.dir): the coefficients (a, b) of the two site relations over
// the 9-sample window along the direction (relation 0: the offsets of even parity -4..4, 1: the
// odd ones -3..3, each summed in increasing order), stored per site class (the parity of the
// coordinate along the direction): a0, a1, b0, b1.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/mlri.glsl"

void main() {
  int x, y;
  if (!region_setup(x, y)) return;
  float a[2], b[2];
  for (int k = 0; k < 2; ++k) {
    precise float si = 0.0, sp = 0.0, sip = 0.0, sii = 0.0;
    bool first = true;
    for (int d = -kRg; d <= kRg; ++d) {
      if ((d & 1) != k) continue;
      precise float gi = guide(x, y, d), pi = raw_along(x, y, d);
      precise float ipi = lap_along(0, x, y, d), iii = lap_along(1, x, y, d);
      if (first) {
        si = gi;
        sp = pi;
        sip = ipi;
        sii = iii;
        first = false;
      } else {
        si += gi;
        sp += pi;
        sip += ipi;
        sii += iii;
      }
    }
    coefficients(si, sp, sip, sii, P.tau_n_g[k], P.inv_n_g[k], a[k], b[k]);
  }
  const bool even = ((P.dir == 0u ? x : y) & 1) == 0;
  coef[pidx(0, x, y)] = even ? a[0] : a[1];
  coef[pidx(1, x, y)] = even ? a[1] : a[0];
  coef[pidx(2, x, y)] = even ? b[0] : b[1];
  coef[pidx(3, x, y)] = even ? b[1] : b[0];
}
