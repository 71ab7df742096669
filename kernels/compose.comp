// Composition, photosite::scene::compose (scene/lights.cpp) after the darken kernel has written
// each pixel's night ambient radiance into `radiance`: adds the low beam's Lambertian reflection
// on ground classes below the horizon and the light map,
//   L_k += t_k · (tint_k/π) · E_beam + lights_k,
//   E_beam = beam_road_lux · d² · exp(-u²/2),  u = (x - W/2) / max(1, beam_half_width·W·d)
// (scene::low_beam_lux), in double as on the CPU, exp through exp64 (common/exp64.glsl). The
// float operations are the CPU's, in its order, so the result is bit-equal wherever float(E_beam)
// is; tests/gpu_test.cpp counts the pixels where it is not.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/philox.glsl"
#include "common/exp64.glsl"
layout(local_size_x = 256) in;

// gpu::ComposeParams (gpu/kernels.h)
layout(push_constant, std430) uniform Params {
  uint width;
  uint height;
  uvec2 ground_mask;  // bit id: class id is a ground class
  double vp_y;
  double beam_half_width;
  double beam_road_lux;
  float tint_over_pi[3];
  uint pad;
} P;
layout(std430, binding = 0) readonly buffer Texture { float tex[]; };
layout(std430, binding = 1) readonly buffer Lights { float lights[]; };
layout(std430, binding = 2) readonly buffer Labels { uint labels[]; };  // uint16 ids, two per word
layout(std430, binding = 3) readonly buffer Depth { float depth[]; };
layout(std430, binding = 4) buffer Out { float radiance[]; };         // darkened in, composed out

void main() {
  const uint i = linear_invocation();
  if (i >= P.width * P.height) return;
  const uint x = i % P.width, y = i / P.width;
  const uint id = (labels[i >> 1] >> (16u * (i & 1u))) & 0xffffu;
  const bool ground = id < 32u ? ((P.ground_mask.x >> id) & 1u) != 0u
                               : id < 64u && ((P.ground_mask.y >> (id - 32u)) & 1u) != 0u;
  float e = 0.0;
  if (double(y) > P.vp_y && ground) {
    const double d = double(depth[i]);
    const double w = double(P.width);
    precise double half_w = max(1.0LF, P.beam_half_width * w * d);
    precise double u = (double(x) - 0.5LF * w) / half_w;
    if (abs(u) <= 4.0LF) {
      precise double lux = P.beam_road_lux * d * d * exp64(-0.5LF * u * u);
      e = float(lux);
    }
  }
  for (uint k = 0; k < 3; ++k) {
    precise float add = tex[3 * i + k] * P.tint_over_pi[k] * e + lights[3 * i + k];
    radiance[3 * i + k] = radiance[3 * i + k] + add;
  }
}
