#include "photosite/rng.h"

#include <cstring>

#include "photosite/checksum.h"

#include "core/rng_detail.h"

namespace photosite {

std::array<uint32_t, 4> Philox4x32::generate(std::array<uint32_t, 4> ctr, std::array<uint32_t, 2> key) {
  const shader::uvec4 w =
      shader::philox4x32_10(shader::uvec4(ctr[0], ctr[1], ctr[2], ctr[3]), shader::uvec2(key[0], key[1]));
  return {w.x, w.y, w.z, w.w};
}

std::array<uint32_t, 4> random_words(uint64_t seed, uint32_t frame, uint64_t pixel, Stream stream) {
  return detail::random_words_inline(seed, frame, pixel, static_cast<uint32_t>(stream));
}

uint64_t seed_from_device_id(const char* device_id) {
  uint64_t h = fnv1a_64(device_id, std::strlen(device_id));
  // SplitMix64 finalizer (Steele, Lea & Flood 2014) to spread the bits.
  h += 0x9e3779b97f4a7c15ull;
  h = (h ^ (h >> 30)) * 0xbf58476d1ce4e5b9ull;
  h = (h ^ (h >> 27)) * 0x94d049bb133111ebull;
  return h ^ (h >> 31);
}

}  // namespace photosite
