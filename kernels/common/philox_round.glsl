// Philox4x32-10 (J. K. Salmon, M. A. Moraes, R. O. Dror & D. E. Shaw, "Parallel random numbers:
// as easy as 1, 2, 3", SC'11), written once in the C++/GLSL common subset (common/prelude.glsl):
// the kernels include it through common/philox.glsl, the C++ library through core/rng_detail.h
// (include/photosite/rng.h declares random_words(); the AVX2 eight-lane copy in
// sensor/poisson.cpp is a documented SIMD twin, checked bit for bit by the tests).
//   key = device/temporal seed (64 bit), counter = (pixel (64 bit), frame, stream),
// each as (low, high) 32-bit halves.
#ifndef PHOTOSITE_PHILOX_ROUND_GLSL
#define PHOTOSITE_PHILOX_ROUND_GLSL

const uint kPhiloxM0 = 0xD2511F53u, kPhiloxM1 = 0xCD9E8D57u;  // multipliers
const uint kPhiloxW0 = 0x9E3779B9u, kPhiloxW1 = 0xBB67AE85u;  // Weyl key increments
const int kPhiloxRounds = 10;

// One round: two 32x32 -> 64-bit products, the halves mixed with the other two words and the key.
PS_FN uvec4 philox4x32_round(uvec4 ctr, uvec2 key) {
  uint hi0, lo0, hi1, lo1;
  umulExtended(kPhiloxM0, ctr.x, hi0, lo0);
  umulExtended(kPhiloxM1, ctr.z, hi1, lo1);
  return uvec4(hi1 ^ ctr.y ^ key.x, lo1, hi0 ^ ctr.w ^ key.y, lo0);
}

PS_FN uvec4 philox4x32_10(uvec4 ctr, uvec2 key) {
  for (int round = 0; round < kPhiloxRounds; ++round) {
    if (round > 0) {
      key.x += kPhiloxW0;
      key.y += kPhiloxW1;
    }
    ctr = philox4x32_round(ctr, key);
  }
  return ctr;
}

// The four words for (seed, frame, pixel, stream); seed and pixel as (low, high) halves.
PS_FN uvec4 random_words(uvec2 seed, uint frame, uvec2 pixel, uint stream) {
  return philox4x32_10(uvec4(pixel.x, pixel.y, frame, stream), seed);
}

#endif
