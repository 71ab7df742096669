// Optics and the photon integral: radiance RGB (W·sr⁻¹·m⁻²) → mean photo-electrons per CFA
// pixel, photosite::mean_signal_electrons with the same per-pixel functions
// (common/sensor_pixel.glsl, written once for both; in double):
//   e = M[c]·(R, G, B), divided by (1 + t²)² for cos⁴θ vignetting, t² = r²·(pitch/f)².
// M is photon_matrix() computed on the host (the spectral integral is per frame, not per
// pixel). Non-physical radiance (negative, NaN, Inf, or an R+G+B that overflows) is reported
// through `bad`: the smallest row-major index of such a pixel (atomicMin), as the CPU reports
// the first one.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/cfa.glsl"
#include "common/philox.glsl"
#include "common/sensor_pixel.glsl"
layout(local_size_x = 256) in;

#include "common/params_photon.glsl"
layout(std430, binding = 0) readonly buffer Radiance { float radiance[]; };
layout(std430, binding = 1) readonly buffer Matrix { double M[12]; };  // [colour][band]
layout(std430, binding = 2) writeonly buffer Electrons { float electrons[]; };
layout(std430, binding = 3) buffer Bad { uint first_bad; };

void main() {
  const uint i = linear_invocation();
  if (i >= P.width * P.height) return;
  const uint x = i % P.width, y = i / P.width;
  const float R = radiance[3 * i], G = radiance[3 * i + 1], B = radiance[3 * i + 2];
  if (!radiance_is_physical(R, G, B)) {
    atomicMin(first_bad, i);
    return;
  }
  const uint c = cfa_color(P.cfa_cell, x, y);
  precise double dx = double(x) - P.cx, dy = double(y) - P.cy;
  precise double dy2 = dy * dy;
  electrons[i] = photon_electrons(M[3 * c], M[3 * c + 1], M[3 * c + 2], R, G, B, dx, dy2, P.pitch_over_f);
}
