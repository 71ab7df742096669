// Linearization, photosite::scene::linearize (scene/darken.cpp) operation for operation: a day
// image of 1 to 4 channels (codes normalised to [0,1], or linear values from an EXR) becomes
// linear sRGB, 3 channels. Integer files go through the same 4097-entry sRGB-decode table with
// linear interpolation (built on the host in double, IEC 61966-2-1 §5.2); negatives clip to 0;
// NaN and Inf are damage: set to 0 here, and the first one in reading order is reported through
// `bad` (atomicMin) for the host to refuse the file.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/philox.glsl"
layout(local_size_x = 256) in;

// gpu::LinearizeParams (gpu/kernels.h)
#include "common/params_linearize.glsl"
layout(std430, binding = 0) readonly buffer In { float day[]; };
layout(std430, binding = 1) readonly buffer Lut { float lut[]; };  // 4097 entries
layout(std430, binding = 2) writeonly buffer Out { float linear_rgb[]; };
layout(std430, binding = 3) buffer Bad { uint first_bad; };

void main() {
  const uint i = linear_invocation();
  if (i >= P.n) return;
  for (uint k = 0; k < 3; ++k) {
    float v = day[i * P.channels + (P.channels >= 3 ? k : 0)];
    if (isnan(v) || isinf(v)) {
      atomicMin(first_bad, i);
      v = 0.0;
    }
    if (v < 0.0) v = 0.0;
    if (P.decode != 0u) {
      precise float t = min(v, 1.0) * 4096.0;
      const int j = min(4095, int(t));
      precise float f = lut[j] + (lut[j + 1] - lut[j]) * (t - float(j));
      v = f;
    }
    linear_rgb[3 * i + k] = v;
  }
}
