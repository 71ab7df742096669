// Private (not installed): the end of a run of equal 16-bit labels, shared by the stages that walk
// label images run by run (scene/geometry.cpp, scene/darken.cpp).
#pragma once
#include <bit>
#include <cstdint>
#include <cstring>

namespace photosite::scene {

// The end of the run of values equal to p[x] in p[x..limit): the first index whose value differs,
// or limit. Four 16-bit labels at a time as one 64-bit word (the first differing lane from the
// lowest set bit of the XOR: little-endian lane order), the rest one at a time.
template <class Index>
inline Index run_end(const uint16_t* p, Index x, Index limit) {
  const uint16_t v = p[x];
  Index e = x + 1;
  if constexpr (std::endian::native == std::endian::little) {
    const uint64_t vv = v * 0x0001000100010001ull;
    for (; e + 4 <= limit; e += 4) {
      uint64_t w;
      std::memcpy(&w, p + e, sizeof w);
      if (const uint64_t d = w ^ vv) return e + static_cast<Index>(std::countr_zero(d) / 16);
    }
  }
  while (e < limit && p[e] == v) ++e;
  return e;
}

}  // namespace photosite::scene
