// Philox4x32-10 for the kernels: the generator itself is common/philox_round.glsl (the same
// source the C++ library compiles), plus the GLSL-only helpers for 64-bit pixel indices and
// the invocation index.
#ifndef PHOTOSITE_PHILOX_GLSL
#define PHOTOSITE_PHILOX_GLSL
#include "common/prelude.glsl"
#include "common/philox_round.glsl"

// first + i as a 64-bit (low, high) pair.
uvec2 pixel_index(uvec2 first, uint i) {
  uint carry;
  const uint lo = uaddCarry(first.x, i, carry);
  return uvec2(lo, first.y + carry);
}

// The linear invocation index of a 1-D job laid out as a 2-D grid of work groups (grids wider
// than 65535 groups wrap into y; the host's grid_1d() makes the layout).
uint linear_invocation() {
  return gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x + gl_GlobalInvocationID.x;
}

#endif
