// div_rn(a, b) and sqrt_rn(a) of common/prelude.glsl, each settled from a first value moved
// shift_ulps floats away from the driver's own float division and square root (for the test that
// they reach the correctly rounded result from wherever a GPU's arithmetic may leave them;
// gpu::rounding_probe). out[2i] = a / b, out[2i + 1] = sqrt(a).
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/philox.glsl"
layout(local_size_x = 256) in;
#include "common/prelude.glsl"
#include "common/prelude_end.glsl"
#include "common/params_rounding.glsl"
layout(std430, binding = 0) readonly buffer In { float ab[]; };  // a0, b0, a1, b1, ...
layout(std430, binding = 1) writeonly buffer Out { float res[]; };

// x moved k floats away from 0 (toward 0 for k < 0), where x is finite and not 0.
float moved(float x, int k) {
  if (x == 0.0 || isinf(x) || isnan(x)) return x;
  return uintBitsToFloat(uint(int(floatBitsToUint(x)) + k));
}

void main() {
  const uint i = linear_invocation();
  if (i >= P.n) return;
  const float a = ab[2 * i], b = ab[2 * i + 1];
  res[2 * i] = div_rn_settle(a, b, moved(a / b, P.shift_ulps));
  res[2 * i + 1] = sqrt_rn_settle(a, moved(sqrt(a), P.shift_ulps));
}
