// LMMSE pass 1: vertical observations dv of Delta = G - X, rows mirrored (reflect-101).
#version 450
#extension GL_GOOGLE_include_directive : enable
#include "common/lmmse.glsl"
layout(std430, binding = 1) writeonly buffer Dv { float dv[]; };

void main() {
  const uint i = linear_invocation();
  if (!frame_setup(i)) return;
  const int x = int(i % P.width), y = int(i / P.width);
  dv[i] = observation(fetch(x, y - 2), fetch(x, y - 1), fetch(x, y), fetch(x, y + 1), fetch(x, y + 2),
                      delta_sign(x, y));
}
