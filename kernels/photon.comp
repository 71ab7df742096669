// Optics and the photon integral: radiance RGB (W·sr⁻¹·m⁻²) → mean photo-electrons per CFA
// pixel, photosite::mean_signal_electrons with the same per-pixel functions
// (common/sensor_pixel.glsl, written once for both; in double):
//   e = M[c]·(R, G, B), divided by (1 + t²)² for cos⁴θ vignetting, t² = r²·(pitch/f)².
// M is photon_matrix() computed on the host (the spectral integral is per frame, not per
// pixel). Non-physical radiance (negative, NaN, Inf, or an R+G+B that overflows) is reported
// through `bad`: the smallest row-major index of such a pixel (atomicMin), as the CPU reports
// the first one.
// With the lens's glare (glare != 0): the radiance first becomes keep·L + s_c·up(acc_1), the
// last bilinear upsample of the glare pyramid and its mix (common/glare.glsl, which
// sensor/glare.cpp's glare_row runs too), in float and in that order; the bad-pixel check reads
// the radiance before it.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/cfa.glsl"
#include "common/philox.glsl"
#include "common/sensor_pixel.glsl"
#include "common/glare.glsl"
layout(local_size_x = 256) in;

#include "common/params_photon.glsl"
layout(std430, binding = 0) readonly buffer Radiance { float radiance[]; };
layout(std430, binding = 1) readonly buffer Matrix { double M[12]; };  // [colour][band]
layout(std430, binding = 2) writeonly buffer Electrons { float electrons[]; };
layout(std430, binding = 3) buffer Bad { uint first_bad; };
layout(std430, binding = 4) readonly buffer Acc1 { float acc1[]; };  // level 1, ceil(w/2) x ceil(h/2) x 3
layout(std430, binding = 5) readonly buffer Scale { float scale[]; };

void main() {
  const uint i = linear_invocation();
  if (i >= P.width * P.height) return;
  const uint x = i % P.width, y = i / P.width;
  const float R = radiance[3 * i], G = radiance[3 * i + 1], B = radiance[3 * i + 2];
  if (!radiance_is_physical(R, G, B)) {
    atomicMin(first_bad, i);
    return;
  }
  precise float g[3] = float[3](R, G, B);
  if (P.glare != 0u) {
    const int aw = int(P.width + 1u) / 2, ah = int(P.height + 1u) / 2;
    const GlareTap ty = glare_up_tap(int(y), ah), tx = glare_up_tap(int(x), aw);
    for (int k = 0; k < 3; ++k) {
      const float t0 = glare_lerp(ty.w0, acc1[3 * (ty.i0 * aw + tx.i0) + k], ty.w1, acc1[3 * (ty.i1 * aw + tx.i0) + k]);
      const float t1 = glare_lerp(ty.w0, acc1[3 * (ty.i0 * aw + tx.i1) + k], ty.w1, acc1[3 * (ty.i1 * aw + tx.i1) + k]);
      g[k] = glare_mix(P.keep, g[k], scale[k], glare_lerp(tx.w0, t0, tx.w1, t1));
    }
  }
  const uint c = cfa_color(P.cfa_cell, x, y);
  precise double dx = double(x) - P.cx, dy = double(y) - P.cy;
  precise double dy2 = dy * dy;
  electrons[i] = photon_electrons(M[3 * c], M[3 * c + 1], M[3 * c + 2], g[0], g[1], g[2], dx, dy2, P.pitch_over_f);
}
