// Per-class darkening, photosite::scene::darken_pixel (scene/darken_detail.h) with the same
// per-pixel functions (common/darken.glsl, written once for both): a Lambertian texture f under
// the class's night illuminance,
//   L_k = f_k · E_k     (E = the ambient illuminance / π, float),
// and for the sky its glow colour scaled by the pixel's relative luminance (double):
//   L_k = glow_k · (Σ K_j f_j) / ρ_sky.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/philox.glsl"
#include "common/darken.glsl"
layout(local_size_x = 256) in;

#include "common/params_darken.glsl"
layout(std430, binding = 0) readonly buffer Texture { float tex[]; };
layout(std430, binding = 1) readonly buffer Labels { uint labels[]; };  // uint16 ids, two per word
layout(std430, binding = 2) writeonly buffer Out { float radiance[]; };

void main() {
  const uint i = linear_invocation();
  if (i >= P.n) return;
  const uint id = (labels[i >> 1] >> (16u * (i & 1u))) & 0xffffu;
  const float t0 = tex[3 * i], t1 = tex[3 * i + 1], t2 = tex[3 * i + 2];
  if (id == P.sky_id) {
    const double yr = darken_sky_relative(P.K[0], P.K[1], P.K[2], P.rho_sky, t0, t1, t2);
    radiance[3 * i] = darken_sky_channel(P.glow[0], yr);
    radiance[3 * i + 1] = darken_sky_channel(P.glow[1], yr);
    radiance[3 * i + 2] = darken_sky_channel(P.glow[2], yr);
    return;
  }
  radiance[3 * i] = darken_lit_channel(t0, P.ambient[0]);
  radiance[3 * i + 1] = darken_lit_channel(t1, P.ambient[1]);
  radiance[3 * i + 2] = darken_lit_channel(t2, P.ambient[2]);
}
