// LMMSE pass 2: horizontal observations zh of Delta over x in [-8, w + 8) (the C++ code's mirrored
// row copy with a 10-sample margin), one row per y.
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/lmmse.glsl"
layout(std430, binding = 1) writeonly buffer Zh { float zh[]; };

void main() {
  const uint i = linear_invocation();
  W = int(P.width);
  H = int(P.height);
  const int wz = W + 16;
  if (i >= uint(wz) * P.height) return;
  const int x = int(i % uint(wz)) - 8, y = int(i / uint(wz));
  zh[i] = observation(fetch(x - 2, y), fetch(x - 1, y), fetch(x, y), fetch(x + 1, y), fetch(x + 2, y),
                      delta_sign(x, y));
}
