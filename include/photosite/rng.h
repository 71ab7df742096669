// Counter-based random numbers: Philox4x32-10 (Salmon, Moraes, Dror & Shaw, "Parallel random
// numbers: as easy as 1, 2, 3", SC'11). Every draw is a pure function of
//   key     = device seed (64 bit)
//   counter = (pixel index (64 bit), frame, stream)
// so a result never depends on thread count, tiling or the order pixels are visited, and the
// GLSL kernels (kernels/common/philox.glsl) produce the very same bits.
#pragma once
#include <array>
#include <cmath>
#include <cstdint>

namespace photosite {

// Streams: independent sequences for the same (seed, frame, pixel).
enum class Stream : uint32_t {
  PhotonShot = 1,
  DarkShot = 2,
  ReadNoise = 3,
  RowNoise = 4,
  ColumnNoise = 5,
  FpnPrnu = 16,
  FpnDsnu = 17,
  FpnDarkRate = 18,
  FpnHotPixel = 19,
  Scene = 32,
  Test = 255,
};

struct Philox4x32 {
  static constexpr uint32_t M0 = 0xD2511F53u, M1 = 0xCD9E8D57u;
  static constexpr uint32_t W0 = 0x9E3779B9u, W1 = 0xBB67AE85u;

  static inline std::array<uint32_t, 4> generate(std::array<uint32_t, 4> ctr,
                                                 std::array<uint32_t, 2> key) {
    for (int round = 0; round < 10; ++round) {
      if (round > 0) { key[0] += W0; key[1] += W1; }
      const uint64_t p0 = static_cast<uint64_t>(M0) * ctr[0];
      const uint64_t p1 = static_cast<uint64_t>(M1) * ctr[2];
      const uint32_t hi0 = static_cast<uint32_t>(p0 >> 32), lo0 = static_cast<uint32_t>(p0);
      const uint32_t hi1 = static_cast<uint32_t>(p1 >> 32), lo1 = static_cast<uint32_t>(p1);
      ctr = {hi1 ^ ctr[1] ^ key[0], lo1, hi0 ^ ctr[3] ^ key[1], lo0};
    }
    return ctr;
  }
};

// The four 32-bit words for (seed, frame, pixel, stream).
inline std::array<uint32_t, 4> random_words(uint64_t seed, uint32_t frame, uint64_t pixel,
                                            Stream stream) {
  return Philox4x32::generate(
      {static_cast<uint32_t>(pixel), static_cast<uint32_t>(pixel >> 32), frame,
       static_cast<uint32_t>(stream)},
      {static_cast<uint32_t>(seed), static_cast<uint32_t>(seed >> 32)});
}

// Uniform in the open interval (0, 1) with 32 bits of resolution: (u + 0.5) / 2^32.
inline double uniform_open(uint32_t u) { return (static_cast<double>(u) + 0.5) * 0x1p-32; }
// Uniform in (0, 1) as float, 24 bits: (u >> 8 + 0.5) / 2^24.
inline float uniform_open_f(uint32_t u) {
  return (static_cast<float>(u >> 8) + 0.5f) * 0x1p-24f;
}

// A standard normal from two words, Box-Muller (exact in distribution up to the 32-bit grid).
inline double normal_from_words(uint32_t a, uint32_t b) {
  const double r = std::sqrt(-2.0 * std::log(uniform_open(a)));
  return r * std::cos(6.283185307179586 * uniform_open(b));
}

// A 64-bit device seed from a textual device id (FNV-1a, then a SplitMix64 finalizer), so
// "cam-front-left" always names the same fixed-pattern maps.
uint64_t seed_from_device_id(const char* device_id);

}  // namespace photosite
