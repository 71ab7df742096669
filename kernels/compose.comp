// Composition, photosite::scene::compose (scene/lights.cpp) after the darken kernel has written
// each pixel's night ambient radiance into `radiance`: adds the low beam's Lambertian reflection
// on the classes it lights (the ground and the vertical surfaces: scene::beam_lit_class_bits) and
// the light map,
//   L_k += t_k · (tint_k/π) · E_beam + lights_k,
// E_beam (lx) read per pixel from `beam` (scene::low_beam_illuminance and add_low_beam_vertical,
// computed on the CPU from the metric ground and depth and the preset's intensity table). The float operations are the CPU's, in
// its order, so the result is bit-equal (tests/gpu_test.cpp).
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/philox.glsl"
layout(local_size_x = 256) in;

// gpu::ComposeParams (gpu/kernels.h)
#include "common/params_compose.glsl"
layout(std430, binding = 0) readonly buffer Texture { float tex[]; };
layout(std430, binding = 1) readonly buffer Lights { float lights[]; };
layout(std430, binding = 2) readonly buffer Labels { uint labels[]; };  // uint16 ids, two per word
layout(std430, binding = 3) readonly buffer Beam { float beam[]; };     // E_beam, lx
layout(std430, binding = 4) buffer Out { float radiance[]; };         // darkened in, composed out

void main() {
  const uint i = linear_invocation();
  if (i >= P.width * P.height) return;
  const uint id = (labels[i >> 1] >> (16u * (i & 1u))) & 0xffffu;
  const bool lit = id < 32u ? ((P.beam_mask.x >> id) & 1u) != 0u
                            : id < 64u && ((P.beam_mask.y >> (id - 32u)) & 1u) != 0u;
  const float e = lit ? beam[i] : 0.0;
  for (uint k = 0; k < 3; ++k) {
    precise float add = tex[3 * i + k] * P.tint_over_pi[k] * e + lights[3 * i + k];
    radiance[3 * i + k] = radiance[3 * i + k] + add;
  }
}
