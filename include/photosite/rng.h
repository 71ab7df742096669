// Counter-based random numbers: Philox4x32-10 (Salmon, Moraes, Dror & Shaw, "Parallel random
// numbers: as easy as 1, 2, 3", SC'11). Every draw is a pure function of
//   key     = device seed (64 bit)
//   counter = (pixel index (64 bit), frame, stream)
// so a result never depends on thread count, tiling or the order pixels are visited, and the
// GLSL kernels compile the same source (kernels/common/philox_round.glsl): the very same bits.
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

// The generator itself is written once, in kernels/common/philox_round.glsl, which the library
// (core/rng.cpp) and the Vulkan kernels both compile.
struct Philox4x32 {
  // The ten rounds on counter ctr with key key.
  static std::array<uint32_t, 4> generate(std::array<uint32_t, 4> ctr, std::array<uint32_t, 2> key);
};

// The four 32-bit words for (seed, frame, pixel, stream): Philox4x32-10 of the counter
// (pixel low, pixel high, frame, stream) under the key (seed low, seed high).
std::array<uint32_t, 4> random_words(uint64_t seed, uint32_t frame, uint64_t pixel, Stream stream);

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
