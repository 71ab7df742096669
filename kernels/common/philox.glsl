// Philox4x32-10 (Salmon et al., SC'11), the same function as include/photosite/rng.h:
//   key = device/temporal seed (64 bit), counter = (pixel (64 bit), frame, stream),
// so a kernel and the CPU path draw the very same 32-bit words for a pixel.
#ifndef PHOTOSITE_PHILOX_GLSL
#define PHOTOSITE_PHILOX_GLSL

const uint kPhiloxM0 = 0xD2511F53u, kPhiloxM1 = 0xCD9E8D57u;
const uint kPhiloxW0 = 0x9E3779B9u, kPhiloxW1 = 0xBB67AE85u;

uvec4 philox4x32_10(uvec4 ctr, uvec2 key) {
  for (int round = 0; round < 10; ++round) {
    if (round > 0) key += uvec2(kPhiloxW0, kPhiloxW1);
    uint hi0, lo0, hi1, lo1;
    umulExtended(kPhiloxM0, ctr.x, hi0, lo0);
    umulExtended(kPhiloxM1, ctr.z, hi1, lo1);
    ctr = uvec4(hi1 ^ ctr.y ^ key.x, lo1, hi0 ^ ctr.w ^ key.y, lo0);
  }
  return ctr;
}

// random_words(seed, frame, pixel, stream): seed and pixel as (low, high) 32-bit halves.
uvec4 random_words(uvec2 seed, uint frame, uvec2 pixel, uint stream) {
  return philox4x32_10(uvec4(pixel.x, pixel.y, frame, stream), seed);
}

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
