// Private (not installed): the end of a run of equal 16-bit labels (or 32-bit region numbers), shared by the stages that walk
// label images run by run (scene/geometry.cpp, scene/darken.cpp).
#pragma once
#include <bit>
#include <cstdint>
#include <cstring>
#include <type_traits>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace photosite::scene {

// The end of the run of values equal to p[x] in p[x..limit): the first index whose value differs,
// or limit. For 16- and 32-bit values: with SSE2 (every x86-64), sixteen bytes of them at a time
// by a lane compare (the first differing lane from the lowest clear bit of the byte mask);
// elsewhere eight bytes at a time as one 64-bit word (the first differing lane from the lowest
// set bit of the XOR, on little-endian machines); the rest one at a time.
template <class T, class Index>
inline Index run_end(const T* p, Index x, Index limit) {
  static_assert(sizeof(T) == 2 || sizeof(T) == 4);
  const T v = p[x];
  Index e = x + 1;
#if defined(__SSE2__)
  constexpr int lanes = 16 / sizeof(T);
  const __m128i vv = sizeof(T) == 2 ? _mm_set1_epi16(static_cast<short>(v)) : _mm_set1_epi32(static_cast<int>(v));
  for (; e + lanes <= limit; e += lanes) {
    const __m128i w = _mm_loadu_si128(reinterpret_cast<const __m128i*>(p + e));
    const int eq = _mm_movemask_epi8(sizeof(T) == 2 ? _mm_cmpeq_epi16(w, vv) : _mm_cmpeq_epi32(w, vv));
    if (eq != 0xffff) return e + static_cast<Index>(std::countr_zero(static_cast<unsigned>(~eq)) / sizeof(T));
  }
#else
  if constexpr (std::endian::native == std::endian::little) {
    constexpr int lanes = 8 / sizeof(T);
    using U = std::conditional_t<sizeof(T) == 2, uint16_t, uint32_t>;
    const uint64_t vv = static_cast<U>(v) * (sizeof(T) == 2 ? 0x0001000100010001ull : 0x0000000100000001ull);
    for (; e + lanes <= limit; e += lanes) {
      uint64_t w;
      std::memcpy(&w, p + e, sizeof w);
      if (const uint64_t d = w ^ vv) return e + static_cast<Index>(std::countr_zero(d) / (8 * sizeof(T)));
    }
  }
#endif
  while (e < limit && p[e] == v) ++e;
  return e;
}

}  // namespace photosite::scene
